"""Write virtual-rig runs as recordings (interface.md), beside the rig file the engineer believes.

This is the virtual rig's I/O layer: it uses :mod:`brake_hil.io.recording_writer` (rosbags and
mcap, no ROS install). A recording is a rosbag2 MCAP directory with the measured ``p_i``,
``p_b``, ``F_k``, ``x_c`` (and ``p_a`` when the air drives the rig), raw at 1 kHz, stamped with
the sample times; the rig YAML written with it holds the *nominal* values, not the truth.
"""

from __future__ import annotations

from pathlib import Path

from brake_hil.io.recording_writer import DEFAULT_START_STAMP_NS, write_recording
from brake_hil.physics.rig import Rig
from brake_hil.topics import QUANTITY_TOPICS
from brake_hil.virtual_rig.rig_yaml import write_rig
from brake_hil.virtual_rig.simulator import RigRun


def write_run(
    run: RigRun,
    path: Path | str,
    *,
    nominal_rig: Rig | None = None,
    rig_path: Path | str | None = None,
    start_stamp_ns: int = DEFAULT_START_STAMP_NS,
) -> Path:
    """Write the run's measured channels as a new rosbag2 MCAP directory ``path``.

    Args:
        run: a virtual-rig run.
        path: the recording directory to create (must not exist).
        nominal_rig: the rig as the test engineer believes it; written to ``rig_path``.
        rig_path: where the nominal rig YAML goes (default: ``<path>.rig.yaml`` beside it).
        start_stamp_ns: ``header.stamp`` of the first sample (ns since the epoch).

    Returns:
        ``path`` as a Path.

    Raises:
        FileExistsError: ``path`` exists.
    """
    path = Path(path)
    channels = {QUANTITY_TOPICS[key]: values for key, values in run.measured.items()}
    write_recording(path, run.time, channels, start_stamp_ns=start_stamp_ns)
    if nominal_rig is not None:
        target = (
            Path(rig_path) if rig_path is not None else path.with_name(path.name + ".rig.yaml")
        )
        write_rig(
            nominal_rig,
            target,
            f"Rig file for the recording {path.name} (nominal values, as the test engineer\n"
            "knows them; the virtual rig that made the recording differs from it).",
        )
    return path
