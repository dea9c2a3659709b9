"""Pressure source node: the rig's input ``p_i`` (and its measurements) on the ROS graph.

Publishes ``/brake/master_cylinder/pressure`` and, when the source has them, the measured
``/brake/bore/pressure``, ``/brake/block/force``, ``/brake/caliper/displacement`` (and
``/brake/air/pressure``), one message per sample, ``header.stamp`` = the sample's acquisition
time. Two modes:

``replay``
    A recording (rosbag2 directory, ``.mcap`` or ``.db3``; read by
    :func:`~brake_hil.io.recording_reader.read_recording`) played paced by its samples'
    stamps, at real time or ``rate`` times it, from ``start_offset`` for ``duration``,
    optionally looped. Samples are published at absolute deadlines (monotonic clock, sleep
    then spin); a late wake-up publishes the samples that fell due back to back, never skips
    one. Stamps (``stamp_mode``): ``shift`` (default) moves every recorded stamp by one offset
    so the first replayed sample is stamped with the wall-clock time of its publication: at
    rate 1 each stamp is the time the sample is "acquired" on this host, as live data would be,
    and the spacing is the recording's. ``keep`` publishes the recorded stamps. Each further
    loop pass adds the recording's span plus one sample interval, so stamps always increase.
    Topics are renamed with ROS remapping (``--ros-args -r /brake/bore/pressure:=/rig2/p_b``).

``can``
    The rig's DAQ over CAN (python-can ``can_interface``/``can_channel``/``can_bitrate``), frames
    decoded with the DBC ``dbc_file`` by :class:`~brake_hil.io.can_daq.CanDaq` into ``p_i``,
    ``p_b``, ``F_k``, ``x_c`` (and ``p_a``), stamped with their acquisition time (the DAQ's
    sample counter on the host clock). Every decoded sample is published once; nothing is
    ever republished, so a silent bus publishes nothing, and a frame whose sample counter
    does not advance (a frozen DAQ repeating itself) is dropped and counted, never published
    as fresh. Staleness is a deadline armed per good frame (``stale_after_ms`` after it): a
    watchdog thread sleeps until that absolute deadline and, unless a good frame has moved
    it meanwhile, publishes ``pressure_source: daq`` STALE at once (the delay from the last
    frame to that report is kept: ``stale_report_ms`` on diagnostics, all of them in the
    statistics file). Bus errors and a lost adapter are reported after the poll that saw
    them (polls are at most 1 ms apart); a lost adapter is reopened with backoff, without
    crashing.

Parameters: :class:`~brake_hil.nodes.settings.PressureSourceSettings` (``config/nodes.yaml``).
"""

from __future__ import annotations

from collections.abc import Sequence
import sys

from brake_hil.nodes.entry import run_entry

NAME = "pressure_source"


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``pressure_source``: its help, or the node run until SIGINT/SIGTERM."""
    return run_entry(NAME, args)


if __name__ == "__main__":
    sys.exit(main())
