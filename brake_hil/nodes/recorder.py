"""Recorder node: every ``/brake/**`` topic and ``/diagnostics`` into a rosbag2 MCAP directory.

A thin adapter over :class:`brake_hil.io.mcap_recorder.McapRecorder`: it discovers matching
topics as they appear (graph searched every ``discovery_interval_s``) and subscribes to each
with a raw subscription (the serialised CDR bytes are written as they arrive, never decoded).

All its work runs on one thread (``recorder-loop``), every ``take_interval_s``: it takes what
the middleware holds for each topic (:class:`~brake_hil.nodes.common.PolledSubscription`, as
the comparator does: no executor, no Python callback per message, about half the CPU of
rclpy's EventsExecutor at 7 topics x 1 kHz) and writes it in receive-time order. A message's
log time is its receive time (the middleware's ``received_timestamp``, system clock; the
take's time where the middleware gives none), never earlier than the topic's previous
message (a reliable sample repaired after a gap arrives after newer ones but is delivered, and
recorded, in the topic's order); ``header.stamp`` stays inside the message. A message
received after a take began waits for the next take, so log times never go backwards.
SIGINT/SIGTERM stop the loop, record what the middleware
still holds (until 0.05 s without a message, at most 0.5 s: under steady traffic up to 0.5 s
more is recorded), then finish the files.

Parameters: :class:`~brake_hil.nodes.settings.RecorderSettings` (``config/recorder.yaml``).

Subscriptions are reliable, volatile, keep-last ``qos_depth``; a topic whose publishers offer
only best effort is subscribed best effort (a reliable reader would not match them).

The open chunk is committed once it is ``flush_interval_s`` old, so ``kill -9`` loses at most
that span of messages plus what the middleware had not yet delivered (and one take's worth);
``metadata.yaml`` is rewritten at most every ``metadata_interval_s`` (readers of a killed
recording count its files themselves). A failed write (disk full, file size limit, I/O
error) stops the recording (:class:`~brake_hil.io.mcap_recorder.McapRecorder`: the file is
cut back to its last whole chunk, every message written before stays readable): the node
stops writing, publishes an ERROR status ``recorder`` on ``/diagnostics`` (the only status
it publishes), closes the files as they stand, prints one line and exits with status 1.
"""

from __future__ import annotations

from collections.abc import Sequence
import sys

from brake_hil.nodes.entry import run_entry

NAME = "recorder"


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``recorder``: its help, or the node run until SIGINT/SIGTERM."""
    return run_entry(NAME, args)


if __name__ == "__main__":
    sys.exit(main())
