"""A small virtual lab: rigs recorded once a day, one of them wearing, for ``brake-hil trend``.

Two rigs of the seed's one-washer design, each described by its own rig file (its ``name``
is what ``trend --rig`` selects), recorded once a day for ``runs`` days:

* ``rig-1`` *wears*: its seals stick and slip more from run to run (``seal_stick_slip``
  strength :data:`SEAL_WEAR` from first to last run) and air collects in its fluid
  (``entrained_air`` strength :data:`AIR_GROWTH`);
* ``rig-2`` is *steady*: the same mild seal stick-slip (:data:`STEADY_SEAL`) in every run.

Both see the day's temperature as a fluid viscosity a few per cent off (:data:`DAILY_VISCOSITY`
one sigma) and fresh sensor noise. Each rig's truth differs from its rig file within half its
tolerances, drawn once. What was simulated is written apart from the recordings
(``DIR/truth.json``), which neither ``diagnose`` nor ``trend`` reads.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
import json
from pathlib import Path
from typing import Any

import numpy as np

from brake_hil import __version__
from brake_hil.physics.excitation import SEED_MAX_PRESSURES
from brake_hil.physics.rig import Rig
from brake_hil.virtual_rig.bag import write_run
from brake_hil.virtual_rig.cases import nominal_rigs, truth_rig
from brake_hil.virtual_rig.draws import draw_parameter_errors
from brake_hil.virtual_rig.effects import Effect, make_effect
from brake_hil.virtual_rig.excitation import seed_pulsing
from brake_hil.virtual_rig.rig_yaml import rig_with_values
from brake_hil.virtual_rig.simulator import simulate_rig

__all__ = [
    "AIR_GROWTH",
    "DAILY_VISCOSITY",
    "FIRST_DAY",
    "FLEET_RIGS",
    "FleetRun",
    "SEAL_WEAR",
    "STEADY_SEAL",
    "make_fleet_run",
    "plan_fleet",
    "write_truth",
]

SEAL_WEAR = (0.1, 0.9)
"""``seal_stick_slip`` strength of the wearing rig in its first and last run (linear)."""
AIR_GROWTH = (0.0, 0.5)
"""``entrained_air`` strength of the wearing rig in its first and last run (linear)."""
STEADY_SEAL = 0.3
"""``seal_stick_slip`` strength of the steady rig, every run."""
DAILY_VISCOSITY = 0.02
"""One sigma of the day's relative fluid-viscosity change (temperature), -."""
FIRST_DAY = datetime(2026, 10, 1, 7, 0, tzinfo=UTC)
"""Start of the first run; one run a day after it."""
FLEET_RIGS = {"rig-1": ("one_washer_open", "wearing"), "rig-2": ("one_washer_open", "steady")}
"""Rig name -> (nominal rig of :func:`~brake_hil.virtual_rig.cases.nominal_rigs`, story)."""
_ERROR_SCALE = 0.5  # of the tolerances: each rig's truth against its rig file


@dataclass(frozen=True)
class FleetRun:
    """One day's recording of one rig, before it is simulated."""

    rig_name: str  # the rig file's name (FLEET_RIGS)
    run: int  # 0, 1, ... in time order
    runs: int  # runs of this rig in all
    start: datetime  # first sample, UTC
    effects: tuple[Effect, ...]
    parameter_errors: dict[str, float]  # truth / rig file - 1, the same every run of a rig
    viscosity_change: float  # the day's relative viscosity change, -
    noise_seed: int

    @property
    def folder(self) -> str:
        """The recording's path under the fleet directory: ``rig-1/run-07``."""
        return f"{self.rig_name}/run-{self.run + 1:02d}"


def _wear(run: int, runs: int, span: tuple[float, float]) -> float:
    share = run / max(runs - 1, 1)
    return round(span[0] + share * (span[1] - span[0]), 4)


def plan_fleet(runs: int = 30, seed: int = 0) -> list[FleetRun]:
    """Every rig's runs in time order; every draw from ``default_rng([seed, rig, run])``."""
    if runs < 1:
        raise ValueError(f"runs must be at least 1, not {runs}")
    rigs = nominal_rigs()
    plan = []
    for rig_index, (name, (nominal_key, story)) in enumerate(FLEET_RIGS.items()):
        errors = draw_parameter_errors(  # the lab's own stored draw, unchanged
            rigs[nominal_key], np.random.default_rng([seed, rig_index]), _ERROR_SCALE, "seed"
        )
        for run in range(runs):
            rng = np.random.default_rng([seed, rig_index, run + 1])
            if story == "wearing":
                strengths = {
                    "seal_stick_slip": _wear(run, runs, SEAL_WEAR),
                    "entrained_air": _wear(run, runs, AIR_GROWTH),
                }
            else:
                strengths = {"seal_stick_slip": STEADY_SEAL}
            effects = tuple(
                make_effect(effect, strength)
                for effect, strength in strengths.items()
                if strength > 0.0
            )
            plan.append(
                FleetRun(
                    rig_name=name,
                    run=run,
                    runs=runs,
                    start=FIRST_DAY + timedelta(days=run, hours=2 * rig_index),
                    effects=effects,
                    parameter_errors=errors,
                    viscosity_change=round(float(rng.normal(0.0, DAILY_VISCOSITY)), 4),
                    noise_seed=int(rng.integers(0, 2**31 - 1)),
                )
            )
    return plan


def _nominal(run: FleetRun) -> Rig:
    """The rig file of ``run``'s rig: its nominal rig under the rig's name."""
    nominal = nominal_rigs()[FLEET_RIGS[run.rig_name][0]]
    return rig_with_values(nominal, {}, name=run.rig_name)


def make_fleet_run(run: FleetRun, out: Path, pulsing_s: float = 5.0) -> dict[str, Any]:
    """Simulate and write one run under ``out``; return what was simulated (its label).

    Writes the recording ``out/<rig>/run-NN/`` and its rig file ``run-NN.rig.yaml`` beside it
    (the rig as its test engineer describes it, the same for every run of a rig).
    """
    nominal = _nominal(run)
    truth = truth_rig(nominal, run.parameter_errors, f"truth of {run.folder}")
    viscosity = truth.fluid.viscosity * (1.0 + run.viscosity_change)
    truth = rig_with_values(truth, {"fluid.viscosity": viscosity})
    excitation = seed_pulsing(
        SEED_MAX_PRESSURES, pulsing_s=pulsing_s, pulsing_hz=truth.excitation_hz
    )
    simulated = simulate_rig(truth, run.effects, excitation, seed=run.noise_seed)
    recording = out / run.folder
    recording.parent.mkdir(parents=True, exist_ok=True)
    write_run(
        simulated,
        recording,
        nominal_rig=nominal,
        start_stamp_ns=int(run.start.timestamp()) * 1_000_000_000,
    )
    return {
        "rig": run.rig_name,
        "story": FLEET_RIGS[run.rig_name][1],
        "run": run.run + 1,
        "start": run.start.isoformat(),
        "effects": [{"name": e.name, "parameters": e.values()} for e in run.effects],
        "parameter_errors": run.parameter_errors,
        "viscosity_change": run.viscosity_change,
        "noise_seed": run.noise_seed,
    }


def write_truth(out: Path, labels: dict[str, dict[str, Any]], runs: int, seed: int) -> Path:
    """Write ``out/truth.json``: how the fleet was made and each run's label, by folder."""
    document = {
        "generator": {
            "tool": f"brake_hil {__version__} virtual rig",
            "runs": runs,
            "seed": seed,
            "rigs": {name: story for name, (_, story) in FLEET_RIGS.items()},
            "layout": "RIG/run-NN (rosbag2 MCAP) + RIG/run-NN.rig.yaml (the rig file)",
        },
        "runs": dict(sorted(labels.items())),
    }
    path = out / "truth.json"
    path.write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
    return path
