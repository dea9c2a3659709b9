"""How often the trend's rules speak on steady rigs, and whether they find a wearing one.

Builds synthetic fleets of diagnoses (``test/results/fleets.py``: steady rigs with offsets
within the band and heavy-tailed, day-to-day correlated scatter up to a third of the
tolerance) of each length given, trends each (:func:`brake_hil.results.trend.rig_trend`) and
prints, per length, the share of fleets that got any line, and the share the rule "a run
outside its band" (``OUTSIDE_SIGMA`` tolerances from the rig file, said at once) spoke on;
then, on ``brake-hil fleet``'s wearing seal (k_eh falling from 0.84 to 0.12 of the rig file's,
tolerance ±50 %, over each length), the share found. Last, the air as the improved model holds
it beside a seal named in every run (``carry_air``): the share of steady fleets whose air got a
line, and of fleets whose air rose 2.2 times (the 30-run lab's wearing rig) that got one.

    .venv/bin/python benchmarks/bench_trend_alarms.py [--fleets 200] [--runs 5,10,30]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
import sys

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from brake_hil.results.trend import OUTSIDE_SIGMA, Movement, rig_trend  # noqa: E402
from test.results.fleets import carry_air, rows, steady_fleet  # noqa: E402


def _wearing_found(seed: int, runs: int) -> bool:
    fleet = steady_fleet(np.random.default_rng(seed), runs)
    for number, run in enumerate(fleet):
        fall = 0.843 - (0.843 - 0.117) * number / (runs - 1)
        run.logs["effective_hydraulic_stiffness"] = math.log(fall)
        run.identified["effective_hydraulic_stiffness"] = True
    trend = rig_trend(rows(fleet))
    seal = next(s for s in trend.series if s.name == "effective_hydraulic_stiffness")
    return seal.finding is not None


def _carried_line(seed: int, runs: int, rise: float) -> bool:
    fleet = carry_air(
        np.random.default_rng(seed + 1), steady_fleet(np.random.default_rng(seed), runs), rise
    )
    return any(s.modelled and s.finding for s in rig_trend(rows(fleet)).series)


def main() -> int:
    """Print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--fleets", type=int, default=200)
    parser.add_argument("--runs", default="5,10,30")
    args = parser.parse_args()
    print(f"outside rule: {OUTSIDE_SIGMA:g} tolerances; {args.fleets} fleets per length")
    print(
        f"{'runs':>5} {'any line':>10} {'outside rule':>13} {'wearing found':>14} "
        f"{'air, steady':>12} {'air x2.2 found':>15}"
    )
    for runs in (int(r) for r in args.runs.split(",")):
        lines = outside = found = carried = risen = 0
        for seed in range(args.fleets):
            trend = rig_trend(rows(steady_fleet(np.random.default_rng(seed), runs)))
            lines += bool(trend.findings)
            outside += any(s.movement is Movement.OUTSIDE for s in trend.series)
            found += _wearing_found(100_000 + seed, runs)
            carried += _carried_line(200_000 + seed, runs, 1.0)
            risen += _carried_line(300_000 + seed, runs, 2.2)
        share = 100.0 / args.fleets
        print(
            f"{runs:5d} {lines * share:9.2f}% {outside * share:12.2f}% {found * share:13.1f}% "
            f"{carried * share:11.2f}% {risen * share:14.1f}%"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
