"""The diagnosis's confidence fitted on one family of cases and judged on the other.

Reads the JSON of ``brake-hil benchmark --json`` runs of the virtual rig's family ``a`` and of
family ``b`` (``brake-hil cases --family``; several runs per family joined by commas),
replays every verdict from its saved decision inputs (``decide`` is a pure function of
them) to get its decision margin, and fits the confidence's logistic (right / wrong on the
margin, ridge 0.01) on one family; then prints the reliability table (bins, cases, mean
confidence, share right) of that fit on the other family, both ways, of a fit on both, and
of the shipped constants on each.

    python3 benchmarks/bench_confidence.py A1.json,A2.json B1.json

Prints figures only; exits 2 on a file it cannot read.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
import sys

import numpy as np
import scipy.optimize

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from brake_hil.diagnosis import diagnose as diagnosis  # noqa: E402
from brake_hil.diagnosis.diagnose import Summary, decide  # noqa: E402

BINS = ((0.0, 0.5), (0.5, 0.7), (0.7, 0.8), (0.8, 0.9), (0.9, 0.95), (0.95, 1.01))
RIDGE = 0.01


def margins_and_rightness(paths: str) -> tuple[np.ndarray, np.ndarray]:
    """Each scored case's decision margin (replayed) and whether its verdict was right."""
    cases = []
    for name in paths.split(","):
        path = Path(name)
        try:
            cases += json.loads(path.read_text(encoding="utf-8")).get("per_case", [])
        except (OSError, json.JSONDecodeError, AttributeError) as error:
            print(f"{path}: cannot read benchmark figures: {error}", file=sys.stderr)
            raise SystemExit(2) from error
    margins, right = [], []
    for case in cases:
        if case.get("error") or not case.get("summary"):
            continue
        verdict = decide(Summary.from_dict(case["summary"]))
        margins.append(min(verdict.margin, 50.0))
        right.append(set(verdict.effects) == set(case["label"]))
    return np.array(margins), np.array(right, dtype=float)


def fit_logistic(margin: np.ndarray, right: np.ndarray) -> tuple[float, float]:
    """Slope and offset of P(right) = logistic(slope * margin + offset), ridge ``RIDGE``."""

    def loss(x: np.ndarray) -> float:
        z = x[0] * margin + x[1]
        return float(np.sum(np.logaddexp(0.0, -z) * right + np.logaddexp(0.0, z) * (1 - right)))

    result = scipy.optimize.minimize(
        lambda x: loss(x) + RIDGE * float(x @ x), np.array([1.0, 1.0]), method="BFGS"
    )
    return float(result.x[0]), float(result.x[1])


def confidence(margin: np.ndarray, slope: float, offset: float) -> np.ndarray:
    """The logistic of the margin."""
    return np.asarray(1.0 / (1.0 + np.exp(-(slope * margin + offset))), dtype=float)


def table(title: str, p: np.ndarray, right: np.ndarray) -> None:
    """The reliability table and the wrong share of sure (>= 0.9) verdicts."""
    print(f"\n{title}")
    print("| confidence | cases | mean confidence | right |")
    print("|---|---|---|---|")
    for low, high in BINS:
        inside = (p >= low) & (p < high)
        if inside.any():
            print(
                f"| {low:.2f}-{min(high, 1.0):.2f} | {int(inside.sum())} | "
                f"{float(p[inside].mean()):.3f} | {int(right[inside].sum())} of "
                f"{int(inside.sum())} ({100 * float(right[inside].mean()):.0f} %) |"
            )
    sure = p >= 0.9
    wrong = int((sure & (right < 0.5)).sum())
    share = wrong / max(int(sure.sum()), 1)
    print(f"wrong among sure verdicts (>= 0.9): {wrong} of {int(sure.sum())} ({share:.1%})")
    log_loss = -float(np.mean(right * np.log(p + 1e-12) + (1 - right) * np.log(1 - p + 1e-12)))
    print(f"log loss {log_loss:.3f}, accuracy {100 * float(right.mean()):.1f} % of {right.size}")


def main() -> int:
    """Fit on each family, judge on the other."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("family_a", help="benchmark JSON of family a's cases (F1,F2,...)")
    parser.add_argument("family_b", help="benchmark JSON of family b's cases (F1,F2,...)")
    args = parser.parse_args()
    data = {"a": margins_and_rightness(args.family_a), "b": margins_and_rightness(args.family_b)}
    shipped = (diagnosis.CONFIDENCE_SLOPE, diagnosis.CONFIDENCE_OFFSET)
    for name, (margin, right) in data.items():
        table(f"shipped constants {shipped} on family {name}", confidence(margin, *shipped), right)
    both = tuple(np.concatenate([data["a"][k], data["b"][k]]) for k in (0, 1))
    slope, offset = fit_logistic(*both)
    print(f"\nfitted on both families: slope {slope:.3f}, offset {offset:.3f}")
    for fitted_on, judged_on in (("a", "b"), ("b", "a")):
        slope, offset = fit_logistic(*data[fitted_on])
        margin, right = data[judged_on]
        table(
            f"fitted on family {fitted_on} (slope {slope:.3f}, offset {offset:.3f}), "
            f"judged on family {judged_on}",
            confidence(margin, slope, offset),
            right,
        )
    if math.isnan(float(np.mean(data["a"][1]))):
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
