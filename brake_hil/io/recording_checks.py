"""The recording door: what a recording must be before and after it is decoded.

Before any library opens it (:func:`check_recording_path`): the path is a regular file or a
folder (a FIFO, socket or device is refused before it is opened: reading one blocks
forever), every file a rosbag2 folder names is a regular file, the files together are at
most :data:`MAX_RECORDING_BYTES`, and ``metadata.yaml`` passes the strict YAML door of
:mod:`brake_hil.files`. A bag whose topics are serialised in a format other than CDR is
named with its format and its topics (:func:`unsupported_format`).

After decoding, each channel (:func:`check_channel`):

* **Physical bounds.** Every sample within :data:`PHYSICAL_BOUNDS` of its quantity (values
  no brake rig can produce: far outside any sensor's range, wide enough for any rig; the
  seed's sensors span 0-6.9 MPa, 0-8.9 kN and +-0.25 mm). The first sample outside is named
  with its topic and its time.
* **Sample rate.** Taken from the channel's own stamps (the median step), never assumed;
  below :data:`MIN_SAMPLE_RATE_HZ` the channel is refused. The analyses work at the
  recording's own rate.
* **Gaps.** A step between stamps longer than :data:`MAX_GAP_PERIODS` sample periods is a
  gap: the recording is refused, naming the topic, where and how long; gaps are never
  bridged by interpolation.

Every refusal is a :class:`~brake_hil.errors.RecordingError` whose one-line message starts
with the path.
"""

from __future__ import annotations

from collections.abc import Mapping
import os
from pathlib import Path
import stat
from typing import Final, NamedTuple

import numpy as np

from brake_hil.errors import RecordingError
from brake_hil.files import check_input_file, load_yaml, read_text
from brake_hil.topics import TopicSpec
from brake_hil.types import FloatArray, IntArray

__all__ = [
    "MAX_GAP_PERIODS",
    "MAX_METADATA_BYTES",
    "MAX_RECORDING_BYTES",
    "MIN_SAMPLE_RATE_HZ",
    "PHYSICAL_BOUNDS",
    "PhysicalBound",
    "check_channel",
    "check_recording_path",
    "unsupported_format",
]

MAX_RECORDING_BYTES: Final = 2 << 30
"""Largest recording read (2 GiB over all its files: about an hour of every brake topic)."""
MAX_METADATA_BYTES: Final = 1 << 20
"""Largest ``metadata.yaml`` of a rosbag2 folder read (1 MiB)."""
MIN_SAMPLE_RATE_HZ: Final = 200.0
"""Lowest sample rate (Hz) of any channel: 40 samples per 5 Hz cycle, so the 30 Hz low-pass,
the harmonics up to the 5th and a lag of 1 % of a period (``tau/T``) are resolved."""
MAX_GAP_PERIODS: Final = 5.0
"""Longest step between two stamps of one channel, in sample periods, that is not a gap."""


class PhysicalBound(NamedTuple):
    """The values a quantity can physically take on a brake rig (SI), and how fast it moves."""

    low: float
    high: float
    unit: str
    slew: float  # fastest change, unit per second


PHYSICAL_BOUNDS: Final[Mapping[str, PhysicalBound]] = {
    # gauge pressure: not below vacuum (-0.1 MPa, margin for a sensor's offset), not above
    # 50 MPa (beyond any brake line's burst pressure)
    # 10 MPa per ms: ten times a pressure surge's (Joukowsky, 1 m/s of brake fluid: 1 MPa)
    # over a millisecond; the bundled recordings' fastest is 0.05 MPa per ms
    "p_i": PhysicalBound(-1.5e5, 5.0e7, "Pa", 1.0e10),
    "p_b": PhysicalBound(-1.5e5, 5.0e7, "Pa", 1.0e10),
    "p_a": PhysicalBound(-1.5e5, 5.0e6, "Pa", 1.0e10),  # shop air is below 1.6 MPa
    # 100 t, beyond any caliper's clamp force; 100 kN per ms
    "F_k": PhysicalBound(-1.0e6, 1.0e6, "N", 1.0e8),
    # 10 mm (a caliper deflects tens of um); 10 m/s
    "x_c": PhysicalBound(-1.0e-2, 1.0e-2, "m", 10.0),
}
"""Per quantity (``p_i``, ``p_b``, ``F_k``, ``x_c``, ``p_a``; a prediction has its measured
quantity's bound): a sample outside ``low``..``high``, or a step between two samples faster
than ``slew`` (a glitch: 49 MPa for one sample of a 1.4 MPa pulsing), is refused."""

_SPECIAL: Final = {
    stat.S_IFIFO: "a FIFO (named pipe)",
    stat.S_IFSOCK: "a socket",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
}


def _fail(path: Path, problem: str) -> RecordingError:
    return RecordingError(f"{path}: {problem}")


def _metadata(path: Path) -> Mapping[str, object]:
    """The ``rosbag2_bagfile_information`` of a bag folder, through the strict YAML door."""
    meta = path / "metadata.yaml"
    document = load_yaml(
        read_text(meta, "rosbag2 metadata.yaml", RecordingError, MAX_METADATA_BYTES),
        meta,
        RecordingError,
        max_scalar=MAX_METADATA_BYTES,  # QoS profiles are long strings
    )
    info = document.get("rosbag2_bagfile_information") if isinstance(document, dict) else None
    if not isinstance(info, dict):
        raise _fail(meta, "not a rosbag2 metadata.yaml (no rosbag2_bagfile_information)")
    return info


def _storage_files(path: Path, info: Mapping[str, object]) -> list[Path]:
    names = info.get("relative_file_paths")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise _fail(path / "metadata.yaml", "relative_file_paths is not a list of file names")
    return [path / name for name in names]


def check_recording_path(path: Path) -> Mapping[str, object] | None:
    """Refuse a path no reader should open (module docstring); quick, reads no messages.

    Returns:
        A bag folder's ``rosbag2_bagfile_information`` (its ``metadata.yaml``, read through
        the strict YAML door) so the reader need not read it again; ``None`` for a file, a
        missing path or a folder without ``metadata.yaml``.

    Raises:
        RecordingError: not a regular file or folder, an irregular or missing file in a bag
            folder, a folder that cannot be listed, or too many bytes.
    """
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return None  # the reader names a missing path itself
    except OSError as err:
        raise _fail(path, f"cannot read the recording: {err.strerror or err}") from err
    if not (stat.S_ISDIR(mode) or stat.S_ISREG(mode)):
        kind = _SPECIAL.get(stat.S_IFMT(mode), "not a regular file")
        raise _fail(path, f"is {kind}, not a recording (only regular files and folders)")
    if stat.S_ISREG(mode):
        check_input_file(path, "recording", MAX_RECORDING_BYTES, RecordingError)
        return None
    try:
        names = sorted(os.listdir(path))
    except OSError as err:
        raise _fail(path, f"cannot list the recording folder: {err.strerror or err}") from err
    if "metadata.yaml" not in names:
        return None  # the reader explains what a bag folder needs
    info = _metadata(path)
    files = _storage_files(path, info)
    total = 0
    for file in files:
        total += check_input_file(file, "storage file", MAX_RECORDING_BYTES, RecordingError)
    if total > MAX_RECORDING_BYTES:
        raise _fail(
            path, f"{total} bytes of storage files, more than the limit of {MAX_RECORDING_BYTES}"
        )
    return info


def unsupported_format(path: Path) -> str | None:
    """Why a bag folder cannot be decoded, when its topics are not serialised as CDR.

    Returns:
        A problem naming the formats and every topic with its type, format and message
        count, or ``None`` when the metadata declares CDR only (or cannot say).
    """
    if not (path / "metadata.yaml").is_file():
        return None
    try:
        topics = _metadata(path).get("topics_with_message_count")
    except RecordingError:
        return None
    listing, formats = [], set()
    for entry in topics if isinstance(topics, list) else []:
        meta = entry.get("topic_metadata", {}) if isinstance(entry, dict) else {}
        if not isinstance(meta, dict):
            continue
        form = str(meta.get("serialization_format", "cdr"))
        formats.add(form)
        count = entry.get("message_count", "?")
        listing.append(f"{meta.get('name')} ({meta.get('type')}, {form}, {count} messages)")
    odd = sorted(formats - {"cdr"})
    if not odd:
        return None
    return (
        f"serialization format {', '.join(odd)} is not supported (only cdr, what ROS 2's "
        f"default middleware writes); the bag holds {', '.join(listing)}"
    )


def check_channel(path: Path, spec: TopicSpec, stamps_ns: IntArray, values: FloatArray) -> None:
    """Refuse one decoded channel outside its physical bounds, too slow, or with a gap.

    Args:
        path: the recording (for the message).
        spec: the channel's topic.
        stamps_ns: its ``header.stamp`` values (ns), increasing (the reader checked).
        values: its samples (SI), finite (the reader checked).

    Raises:
        RecordingError: naming the topic and the first offending sample's time.
    """
    origin = int(stamps_ns[0])
    bound = PHYSICAL_BOUNDS.get(spec.quantity)
    if bound is not None:
        outside = np.flatnonzero((values < bound.low) | (values > bound.high))
        if outside.size:
            i = int(outside[0])
            raise _fail(
                path,
                f"topic {spec.name}: {outside.size} of {values.size} samples outside the "
                f"physical bounds {bound.low:g} to {bound.high:g} {bound.unit} of "
                f"{spec.quantity}, the first {values[i]:.6g} {bound.unit} at "
                f"{(int(stamps_ns[i]) - origin) / 1e9:.6f} s into the topic (sample {i}, "
                f"stamp {int(stamps_ns[i])} ns)",
            )
    steps = np.diff(stamps_ns)
    if bound is not None:
        speed = np.abs(np.diff(values)) / (steps / 1e9)
        fast = np.flatnonzero(speed > bound.slew)
        if fast.size:
            i = int(fast[0])
            raise _fail(
                path,
                f"topic {spec.name}: {spec.quantity} jumps from {values[i]:.6g} to "
                f"{values[i + 1]:.6g} {bound.unit} in {steps[i] / 1e6:.4g} ms at "
                f"{(int(stamps_ns[i]) - origin) / 1e9:.6f} s into the topic (sample {i}), "
                f"faster than physically possible ({bound.slew:g} {bound.unit}/s; "
                f"{fast.size} such steps)",
            )
    period_ns = float(np.median(steps))
    rate = 1e9 / period_ns
    if rate < MIN_SAMPLE_RATE_HZ:
        raise _fail(
            path,
            f"topic {spec.name} is sampled at {rate:.4g} Hz (median step of its stamps), "
            f"below the minimum of {MIN_SAMPLE_RATE_HZ:g} Hz",
        )
    gaps = np.flatnonzero(steps > MAX_GAP_PERIODS * period_ns)
    if gaps.size:
        i = int(gaps[0])
        raise _fail(
            path,
            f"topic {spec.name} has a gap of {steps[i] / 1e9:.6g} s at "
            f"{(int(stamps_ns[i]) - origin) / 1e9:.6f} s into the topic (after sample {i}; "
            f"more than {MAX_GAP_PERIODS:g} sample periods of {period_ns / 1e6:.4g} ms; "
            f"{gaps.size} gaps in all): gaps are not bridged, split the recording there",
        )
