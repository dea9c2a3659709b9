"""A good recording and rig file, and the damage the fuzz suite and the corpus do to them.

The good recording is the first 4.6 s of ``bags/one_washer_lti`` (a ramp, then about
2.5 s of 5 Hz pulsing at 1.38 MPa: one steady segment), written again as a rosbag2 MCAP
folder; its rig file is ``bags/one_washer_lti.rig.yaml``. Damage is done to its messages
(dropped, duplicated, stamps moved, values replaced) or to its bytes (truncated, flipped),
and to the rig file's text (types, values, structure).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
import json
from pathlib import Path

import numpy as np

from brake_hil.io.recording_reader import read_recording
from brake_hil.io.recording_writer import TopicSeries, recording_channels, write_topics
from brake_hil.topics import TopicSpec
from brake_hil.types import FloatArray, IntArray

ROOT = Path(__file__).resolve().parents[2]
GOOD_BAG = ROOT / "bags" / "one_washer_lti"
GOOD_RIG = ROOT / "bags" / "one_washer_lti.rig.yaml"
GOOD_SECONDS = 4.6


@dataclass(frozen=True)
class Messages:
    """Each topic's messages: stamps (ns), values (SI) and log times (ns)."""

    topics: Mapping[TopicSpec, tuple[IntArray, FloatArray, IntArray]]

    def write(self, path: Path) -> Path:
        """Write as a rosbag2 MCAP folder (log-time order, stamps as they are)."""
        return write_topics(
            path, {spec: TopicSeries(s, v, log) for spec, (s, v, log) in self.topics.items()}
        )

    def replace(
        self, spec: TopicSpec, stamps: IntArray, values: FloatArray, log: IntArray
    ) -> Messages:
        """A copy with one topic's messages replaced."""
        topics = dict(self.topics)
        topics[spec] = (stamps, values, log)
        return Messages(topics)


@lru_cache(maxsize=1)
def good_messages() -> Messages:
    """The good recording's messages (see the module docstring)."""
    recording = read_recording(GOOD_BAG)
    keep = recording.time < GOOD_SECONDS
    stamps = recording.start_stamp_ns + np.round(recording.time[keep] * 1e9).astype(np.int64)
    return Messages(
        {
            spec: (stamps.copy(), values[keep].copy(), stamps.copy())
            for spec, values in recording_channels(recording).items()
        }
    )


def drop(messages: Messages, spec: TopicSpec, start: int, count: int) -> Messages:
    """Remove ``count`` messages of one topic from index ``start``."""
    stamps, values, log = messages.topics[spec]
    start = start % stamps.size
    keep = np.ones(stamps.size, bool)
    keep[start : start + count] = False
    return messages.replace(spec, stamps[keep], values[keep], log[keep])


def duplicate(messages: Messages, spec: TopicSpec, index: int) -> Messages:
    """Write one message of one topic twice."""
    stamps, values, log = messages.topics[spec]
    index = index % stamps.size
    take = np.insert(np.arange(stamps.size), index, index)
    return messages.replace(spec, stamps[take], values[take], log[take])


def move_stamp(messages: Messages, spec: TopicSpec, index: int, delta_ns: int) -> Messages:
    """Move one message's ``header.stamp`` by ``delta_ns`` (its log time stays)."""
    stamps, values, log = messages.topics[spec]
    stamps = stamps.copy()
    index = index % stamps.size
    stamps[index] = max(int(stamps[index]) + delta_ns, 0)
    return messages.replace(spec, stamps, values, log)


def shift_stamps(messages: Messages, spec: TopicSpec, start: int, delta_ns: int) -> Messages:
    """Move every stamp of one topic from index ``start`` on by ``delta_ns`` (a hole or jump)."""
    stamps, values, log = messages.topics[spec]
    stamps = stamps.copy()
    start = start % stamps.size
    stamps[start:] = np.maximum(stamps[start:] + delta_ns, 0)
    return messages.replace(spec, stamps, values, log)


def set_values(
    messages: Messages, spec: TopicSpec, start: int, count: int, value: float
) -> Messages:
    """Replace ``count`` samples of one topic from ``start`` by ``value``."""
    stamps, values, log = messages.topics[spec]
    values = values.copy()
    start = start % values.size
    values[start : start + count] = value
    return messages.replace(spec, stamps, values, log)


def storage_file(bag: Path) -> Path:
    """The one ``.mcap`` file of a bag folder."""
    return next(bag.glob("*.mcap"))


def truncate(bag: Path, fraction: float) -> None:
    """Cut the bag's MCAP file to ``fraction`` of its bytes."""
    path = storage_file(bag)
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * fraction)])


def flip_bytes(bag: Path, flips: list[tuple[float, int]]) -> None:
    """XOR the byte at each relative position (0..1) with its mask (1..255)."""
    path = storage_file(bag)
    data = bytearray(path.read_bytes())
    for where, mask in flips:
        index = min(int(where * len(data)), len(data) - 1)
        data[index] ^= mask
    path.write_bytes(bytes(data))


def finite_metrics(document: object) -> str | None:
    """A problem when a JSON answer holds a number that is not finite, else ``None``."""

    def walk(value: object, where: str) -> str | None:
        if isinstance(value, float) and not np.isfinite(value):
            return f"{where} = {value}"
        if isinstance(value, dict):
            for key, item in value.items():
                if (problem := walk(item, f"{where}.{key}")) is not None:
                    return problem
        if isinstance(value, list):
            for number, item in enumerate(value):
                if (problem := walk(item, f"{where}[{number}]")) is not None:
                    return problem
        return None

    return walk(document, "")


def close_to(
    metrics: Mapping[str, Mapping[str, float]], baseline: Mapping[str, Mapping[str, float]]
) -> str | None:
    """A problem when compare's channel metrics moved from the baseline's, else ``None``.

    Allowed: 1 percentage point of ptp ratio, 0.5 of tau/T, 0.01 of NRMSE.
    """
    limits = {"ptp_ratio_pct": 1.0, "tau_over_T_pct": 0.5, "nrmse": 0.01}
    for channel, expected in baseline.items():
        for key, limit in limits.items():
            got = metrics[channel][key]
            if not abs(got - expected[key]) <= limit:
                return f"{channel} {key} {got:.4g}, undamaged {expected[key]:.4g}"
    return None


def read_json(path: Path) -> object:
    """A JSON answer file."""
    return json.loads(path.read_text(encoding="utf-8"))


@lru_cache(maxsize=1)
def full_messages() -> Messages:
    """All 18 s of ``bags/one_washer_lti`` (three segments), as messages."""
    recording = read_recording(GOOD_BAG)
    stamps = recording.start_stamp_ns + np.round(recording.time * 1e9).astype(np.int64)
    return Messages(
        {
            spec: (stamps.copy(), values.copy(), stamps.copy())
            for spec, values in recording_channels(recording).items()
        }
    )
