"""``brake-hil fleet``: a small virtual lab's recordings, simulated on Dask, for ``trend``.

:mod:`brake_hil.virtual_rig.fleet` describes the rigs and their runs and simulates one;
:func:`run_fleet` maps that over every run with
:func:`~brake_hil.app.parallel.parallel_map` and writes what was simulated apart from the
recordings (``truth.json``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path

from brake_hil.app.parallel import Outcome, Workers, parallel_map, values
from brake_hil.errors import BrakeHilError
from brake_hil.virtual_rig.fleet import FLEET_RIGS, make_fleet_run, plan_fleet, write_truth

__all__ = ["FleetResult", "run_fleet"]


@dataclass(frozen=True)
class FleetResult:
    """The fleet written."""

    recordings: int
    rigs: tuple[str, ...]
    out: Path
    truth_path: Path  # DIR/truth.json, which neither diagnose nor trend reads


def run_fleet(
    out: Path,
    runs: int = 30,
    seed: int = 0,
    *,
    pulsing_s: float = 5.0,
    workers: Workers | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> FleetResult:
    """Simulate every rig's ``runs`` daily recordings under ``out``.

    Args:
        out: a new or empty directory; gets ``RIG/run-NN/`` with ``RIG/run-NN.rig.yaml``.
        runs: recordings per rig (one a day).
        seed: seed of every draw.
        pulsing_s: seconds of 5 Hz pulsing per maximum pressure (5: 18 s recordings).
        workers: where the simulations run (default: an embedded cluster, one per core).
        progress: called with the recordings written and the number in all.

    Raises:
        BrakeHilError: a bad option, ``out`` not new or empty, or a run that failed (after
            every run ran; no ``truth.json`` then).
    """
    if runs < 2 or pulsing_s <= 0.0:
        raise BrakeHilError("fleet: --runs must be >= 2 and --pulsing-seconds > 0")
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise BrakeHilError(f"{out}: not empty; choose a new directory for the fleet")
    out.mkdir(parents=True, exist_ok=True)
    plan = plan_fleet(runs, seed)
    written = 0

    def report(outcome: Outcome[dict[str, object]]) -> None:
        nonlocal written
        written += 1 if outcome.ok else 0
        if progress is not None:
            progress(written, len(plan))

    if progress is not None:
        progress(0, len(plan))
    simulate = partial(make_fleet_run, out=out, pulsing_s=pulsing_s)
    outcomes = parallel_map(simulate, plan, workers or Workers(), report)
    try:
        labels = values(outcomes)
    except Exception as err:
        raise BrakeHilError(f"{out}: a fleet run could not be simulated: {err}") from err
    truth = write_truth(out, {run.folder: lab for run, lab in zip(plan, labels)}, runs, seed)
    return FleetResult(len(plan), tuple(FLEET_RIGS), out, truth)
