"""Caliper model node: the model stepped live, at 1 kHz, on the master-cylinder pressure.

Subscribes to ``/brake/master_cylinder/pressure`` (``p_i``) and publishes the predicted
``/brake/model/bore/pressure``, ``/brake/model/block/force`` and
``/brake/model/caliper/displacement``, each stamped with the stamp of the input sample it was
computed from (interface.md). A dedicated thread runs a 1 kHz loop on absolute deadlines
(:class:`~brake_hil.runtime.DeadlineLoop`); each tick takes every input sample the
middleware has received since the last tick (the subscription's own ``take``, with the
middleware's receive time) and steps the model once for each, in order
(:class:`~brake_hil.runtime.CatchUpRunner`), so no sample is skipped and the output
equals the offline batch model on the same samples (``LiveModel.batch``: same equilibrium
start at the first sample). The tick's phase follows the input's arrival phase
(:class:`~brake_hil.runtime.PhaseLock`), so a sample waits for its tick a fraction of a
millisecond. That thread is the node's only Python thread (diagnostics are published from
it too): nothing contends with it for the GIL at a deadline. With ``paired_with_source``
(one container with a replaying source: the chain's ``--layout paired``) the source's thread
runs the tick right after publishing each sample, so the two 1 kHz loops are one thread and
never wait for each other's GIL; the loop's own thread takes over when the replay ends. So
the node runs without an executor and without parameter services; its parameters are
read-only, set at start.

The model steps on the raw ``p_i`` it receives. (``brake-hil compare`` filters ``p_i`` with
the seed's 30 Hz zero-phase low-pass first; that filter is not causal, so it cannot run live.
The comparator filters predictions and measurements alike before scoring.)

Parameters: :class:`~brake_hil.nodes.settings.CaliperModelSettings` (``config/nodes.yaml``).
No input sample for ``input_late_ms`` / ``input_silent_ms`` makes the input LATE (WARN) /
SILENT (ERROR) on diagnostics, reported at the next tick. With ``hold_mode: hold`` the model
free-runs on the last input once SILENT, one step a period, the held predictions counted and
the input status saying so (WARN); late real samples whose stamps the hold already covered are
dropped. Input state changes are reported at once, the rest every ``diagnostics_period``.
``sched_fifo`` on diagnostics reports whether ``realtime_priority`` took effect.

Faults never pass as healthy. A NaN or infinite ``p_i`` is not stepped (the model holds its
last good state and input), counted, and ``caliper_model: input`` goes ERROR naming its stamp
at once. A step whose outputs are not finite is not published, counted, and the model starts
again from the equilibrium at the next good input (``caliper_model: model`` ERROR). Each stays
ERROR for ``FAULT_ERROR_S`` after the last one, then WARN with its count for the rest of the
run. A sample stamped at or before the last stepped one is dropped and counted (WARN): no two
predictions ever carry one stamp.

Diagnostics (``/diagnostics``): ``caliper_model: loop`` (period error, tick work, step time,
input wait (arrival to its tick), input-to-prediction latency (arrival to published), stamp
age (stamp to published): median, p99, p99.9, max in us over the last report window; ticks,
late ticks, overruns, skipped slots, samples caught up), ``caliper_model: input`` (state,
silence, samples, predictions, missing, held, lost in transport), ``caliper_model: model``.

SIGINT/SIGTERM: the loop stops, samples still queued are stepped and published, a final
report is published and the statistics file written.
"""

from __future__ import annotations

from collections.abc import Sequence
import sys

from brake_hil.nodes.entry import run_entry

NAME = "caliper_model"


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``caliper_model``: its help, or the node run until SIGINT/SIGTERM."""
    return run_entry(NAME, args)


if __name__ == "__main__":
    sys.exit(main())
