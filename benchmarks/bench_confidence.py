"""The verdict's confidence (reliability.py) fitted on one set of cases, judged on others.

Each set is the decision inputs of diagnosed cases with their truth, one of:

* a folder of ``NNN/diagnosis.json`` (``brake-hil benchmark --keep DIR``, or
  ``brake-hil diagnose CASES --out DIR``) with the ``labels.json`` of ``brake-hil cases``
  beside them or given as ``DIR::LABELS``: right and wrong as the benchmark scores them
  (``is_right``: the rig file's own air, a rig value out of tolerance, more air);
* a ``brake-hil benchmark --json`` file (``per_case``) given as ``FILE::LABELS``;
* a diagnosed lab (``RIG/run-NN/diagnosis.json``) given as ``DIR::TRUTH`` with the lab's
  ``truth.json`` (``brake-hil fleet``): right when the effects are the truth's.

Every verdict is replayed from its saved decision inputs (``decide`` is a pure function of
them). The weights of :mod:`brake_hil.diagnosis.reliability` are fitted by maximum likelihood
(a weak Gaussian prior, ``RIDGE``) on the first sets given before ``--check``; the
reliability table of every set is printed for the shipped weights and the fitted ones.

    python3 benchmarks/bench_confidence.py FIT_SET [FIT_SET ...] --check SET [SET ...]

Prints figures only; exits 2 on a set it cannot read.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
import sys
from typing import Any

import numpy as np
from scipy.optimize import minimize

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from brake_hil.app.benchmark import CaseResult, _as_label, is_right  # noqa: E402
from brake_hil.diagnosis.reliability import (  # noqa: E402
    CAPPED_LOG_ODDS,
    KIND_LOG_ODDS,
    LEAD_LOG_ODDS,
    VerdictTraits,
    reliability,
    traits,
)
from brake_hil.diagnosis.summary import Summary  # noqa: E402
from brake_hil.diagnosis.verdict import decide_effects  # noqa: E402

BINS = ((0.0, 0.3), (0.3, 0.5), (0.5, 0.6), (0.6, 0.7), (0.7, 0.8), (0.8, 0.9), (0.9, 1.01))
RIDGE = 0.3
"""Weight of the Gaussian prior on every weight (a sum of squares): keeps a kind seen a few
times near even odds rather than at certainty."""
KINDS = tuple(KIND_LOG_ODDS)
Case = tuple[VerdictTraits, bool]


def read_set(spec: str) -> list[Case]:
    """The traits of every replayed verdict of a set, and whether it was right."""
    path, _, truth_path = spec.partition("::")
    root = Path(path)
    try:
        truth_file = Path(truth_path) if truth_path else root / "labels.json"
        truth = json.loads(truth_file.read_text(encoding="utf-8"))
        if root.is_file():
            document = json.loads(root.read_text(encoding="utf-8"))
            stored = {c["case"]: (c["summary"], c["verdict"]) for c in document["per_case"]}
            stored = {k: v for k, v in stored.items() if v[0]}
        else:
            stored = _diagnosed(root, truth)
    except (OSError, KeyError, TypeError, json.JSONDecodeError) as error:
        print(f"{spec}: cannot read the set: {error}", file=sys.stderr)
        raise SystemExit(2) from error
    return [_case(key, *stored[key], truth) for key in sorted(stored)]


def _diagnosed(root: Path, truth: dict[str, Any]) -> dict[str, tuple[Any, Any]]:
    """Each case's (or lab run's) decision inputs and stored verdict."""
    keys = truth["runs"] if "runs" in truth else truth["cases"]
    out = {}
    for key in keys:
        found = root / key / "diagnosis.json"
        if found.is_file():
            document = json.loads(found.read_text(encoding="utf-8"))
            out[key] = (document["decision_inputs"], document["verdict"])
    return out


def _case(key: str, inputs: Any, verdict: Any, truth: dict[str, Any]) -> Case:
    """Replay one verdict: its traits, and whether it is right."""
    summary = Summary.from_dict(inputs)
    decided = decide_effects(summary)
    t = traits(summary, decided.effects, decided.capped is not None, decided.margin)
    if "runs" in truth:
        want = sorted(e["name"] for e in truth["runs"][key]["effects"])
        return t, sorted(decided.effects) == want
    result = CaseResult(key, decided.effects, 0.0, 0.0, {}, {}, verdict=dict(verdict))
    return t, is_right(result, _as_label(truth["cases"][key]))


def _design(cases: list[Case]) -> tuple[np.ndarray, np.ndarray]:
    rows = [[float(t.kind == k) for k in KINDS] + [t.lead, float(t.capped)] for t, _ in cases]
    return np.array(rows), np.array([ok for _, ok in cases], dtype=float)


def fit(cases: list[Case]) -> np.ndarray:
    """The weights (one log odds per kind, the lead's, the cap's) of least loss."""
    x, y = _design(cases)

    def loss(w: np.ndarray) -> float:
        z = x @ w
        return float(np.sum(np.logaddexp(0.0, z) - y * z) + RIDGE * np.sum(w**2))

    return np.asarray(minimize(loss, np.zeros(x.shape[1]), method="BFGS").x)


def scored(cases: list[Case], weights: np.ndarray | None) -> list[tuple[float, bool]]:
    """Each verdict's confidence (shipped weights when ``weights`` is None) and rightness."""
    if weights is None:
        return [(reliability(t), ok) for t, ok in cases]
    kinds = dict(zip(KINDS, weights[: len(KINDS)].tolist()))
    lead, capped = weights[len(KINDS) :].tolist()
    return [(reliability(t, kinds, lead, capped), ok) for t, ok in cases]


def log_loss(rows: list[tuple[float, bool]]) -> float:
    """Mean negative log-likelihood of right/wrong under the confidences."""
    terms = [math.log(min(max(p if ok else 1.0 - p, 1e-9), 1.0)) for p, ok in rows]
    return -sum(terms) / max(len(terms), 1)


def table(title: str, rows: list[tuple[float, bool]]) -> None:
    """The reliability table (markdown) and the wrong share of sure (>= 0.9) verdicts."""
    right = sum(ok for _, ok in rows)
    print(f"\n{title}: {len(rows)} verdicts, {right} right, log-loss {log_loss(rows):.3f}")
    print("| confidence | verdicts | mean confidence | right | share right |")
    print("|---|---|---|---|---|")
    for low, high in BINS:
        inside = [(p, ok) for p, ok in rows if low <= p < high]
        if inside:
            mean = sum(p for p, _ in inside) / len(inside)
            hits = sum(ok for _, ok in inside)
            print(
                f"| {low:.1f}-{min(high, 1.0):.1f} | {len(inside)} | {mean:.2f} | {hits} | "
                f"{hits / len(inside):.2f} |"
            )
    sure = [ok for p, ok in rows if p >= 0.9]
    print(f"wrong among sure verdicts (>= 0.9): {len(sure) - sum(sure)} of {len(sure)}")


def main() -> int:
    """Fit on the first sets, judge on every set."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("fit", nargs="+", help="sets the weights are fitted on")
    parser.add_argument("--check", nargs="*", default=[], help="sets they are judged on")
    args = parser.parse_args()
    fit_sets = {spec: read_set(spec) for spec in args.fit}
    check_sets = {spec: read_set(spec) for spec in args.check}
    pooled = [c for cases in fit_sets.values() for c in cases]
    weights = fit(pooled)
    shipped = [*KIND_LOG_ODDS.values(), LEAD_LOG_ODDS, CAPPED_LOG_ODDS]
    names = [*(f"kind {k}" for k in KINDS), "lead", "capped"]
    print(f"fitted on {len(pooled)} verdicts of {', '.join(args.fit)}")
    print("| weight | fitted | shipped |\n|---|---|---|")
    for name, value, ship in zip(names, weights, shipped):
        print(f"| {name} | {value:.2f} | {ship:.2f} |")
    table("fit sets, pooled, fitted weights", scored(pooled, weights))
    table("fit sets, pooled, shipped weights", scored(pooled, None))
    checked = [c for cases in check_sets.values() for c in cases]
    if checked:
        table("check sets, pooled, shipped weights", scored(checked, None))
        table("check sets, pooled, fitted weights", scored(checked, weights))
    for spec, cases in {**fit_sets, **check_sets}.items():
        role = "fit set" if spec in fit_sets else "check set"
        table(f"{spec} ({role}), shipped weights", scored(cases, None))
        table(f"{spec} ({role}), fitted weights", scored(cases, weights))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
