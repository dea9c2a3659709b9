"""Comparator node: predicted against measured, live, with the seed's metrics.

Subscribes to the measured ``/brake/bore/pressure``, ``/brake/block/force``,
``/brake/caliper/displacement`` and the predicted ``/brake/model/...`` topics, pairs
predicted with measured samples by stamp (:class:`~brake_hil.analysis.stamp_scoring.StampPairer`),
and once per excitation cycle (5 Hz) publishes, for each channel, the seed's Table 4-5 metrics
(peak-to-peak ratio %, ``tau/T`` %, NRMSE) of that cycle and of the rolling window of
``window_cycles`` cycles ending with it (:func:`~brake_hil.analysis.stamp_scoring.evaluate_cycle`:
both sides low-passed at 30 Hz, zero phase, steady pulsing only; one guard cycle after it,
so figures lag a cycle) as ``diagnostic_msgs/msg/DiagnosticArray`` on ``/brake/comparison``
and ``/diagnostics``. Cycles lie on a grid of stamps, from the first paired sample, moved
once (by under half a period) to start at a peak of the measured bore pressure, so that
each cycle holds both mean crossings; a late timer scores every cycle that fell due, so none
is skipped. Levels
come from :class:`~brake_hil.analysis.stamp_scoring.Thresholds` on the window's metrics: OK, WARN,
ERROR; STALE while there is nothing paired; OK with "not steady" during ramps and pauses.
While predictions and measurements of a channel both arrive but none has paired for
``NO_MATCH_S`` (a model stamping with its own clock, a source re-stamping), the channel and the
summary are ERROR: "no prediction matches a measurement stamp", published every evaluation.

One thread does the node's work: every quarter cycle (50 ms) it takes what the six subscriptions
hold (no Python callback per message: six 1 kHz topics cost a few per cent of a core), and
once a cycle it scores. There is no executor, hence no parameter services: the
parameters are read-only, set at start.

Parameters: :class:`~brake_hil.nodes.settings.ComparatorSettings` (``config/nodes.yaml``); at
shutdown the run's per-channel means over every steady cycle scored go to ``summary_file``
as JSON.
"""

from __future__ import annotations

from collections.abc import Sequence
import sys

from brake_hil.nodes.entry import run_entry

NAME = "comparator"


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``comparator``: its help, or the node run until SIGINT/SIGTERM."""
    return run_entry(NAME, args)


if __name__ == "__main__":
    sys.exit(main())
