"""The verdict's confidence (its posterior share) fitted on one set of cases, judged on others.

Each set is the decision inputs of diagnosed cases with their truth, one of:

* a ``brake-hil benchmark --json`` file (``per_case``: ``summary`` and ``label``);
* a folder of ``NNN/diagnosis.json`` (``brake-hil diagnose CASES --out DIR``) with a
  ``labels.json`` (``brake-hil cases``'s) beside them or given as ``DIR::LABELS``;
* a diagnosed lab (``RIG/run-NN/diagnosis.json``) given as ``DIR::TRUTH`` with the lab's
  ``truth.json`` (``brake-hil fleet``).

Every verdict is replayed from its saved decision inputs (``decide`` is a pure function of
them). ``EFFECTIVE_SAMPLES`` is fitted (least log-loss of right/wrong over a grid) on the first
set; the reliability table of every set is printed for the shipped constant and the fitted one.

    python3 benchmarks/bench_confidence.py FIT_SET CHECK_SET [CHECK_SET ...]

Prints figures only; exits 2 on a set it cannot read.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
import sys
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from brake_hil.diagnosis.posterior import posterior  # noqa: E402
from brake_hil.diagnosis.summary import Summary  # noqa: E402
from brake_hil.diagnosis.thresholds import EFFECTIVE_SAMPLES  # noqa: E402
from brake_hil.diagnosis.verdict import STAND_IN_MARGIN, _confidence, decide  # noqa: E402

BINS = ((0.0, 0.5), (0.5, 0.7), (0.7, 0.8), (0.8, 0.9), (0.9, 0.95), (0.95, 1.01))
GRID = (5.0, 8.0, 10.0, 12.0, 15.0, 20.0, 25.0, 30.0, 40.0, 60.0)
Case = tuple[Summary, list[str]]


def read_set(spec: str) -> list[Case]:
    """The (decision inputs, true effects) of every diagnosed case of a set."""
    path, _, truth_path = spec.partition("::")
    root = Path(path)
    try:
        if root.is_file():
            cases = json.loads(root.read_text(encoding="utf-8"))["per_case"]
            return [
                (Summary.from_dict(c["summary"]), sorted(c["label"]))
                for c in cases
                if c.get("summary") and not c.get("error")
            ]
        truth_file = Path(truth_path) if truth_path else root / "labels.json"
        truth = json.loads(truth_file.read_text(encoding="utf-8"))
        return _diagnosed(root, truth)
    except (OSError, KeyError, TypeError, json.JSONDecodeError) as error:
        print(f"{spec}: cannot read the set: {error}", file=sys.stderr)
        raise SystemExit(2) from error


def _diagnosed(root: Path, truth: dict[str, Any]) -> list[Case]:
    """Cases' labels (``cases``) or a lab's runs (``runs``) joined with their diagnoses."""
    if "runs" in truth:
        want = {k: sorted(e["name"] for e in v["effects"]) for k, v in truth["runs"].items()}
    else:
        want = {k: sorted(v["expected_effects"]) for k, v in truth["cases"].items()}
    out = []
    for key, effects in sorted(want.items()):
        found = root / key / "diagnosis.json"
        if found.is_file():
            document = json.loads(found.read_text(encoding="utf-8"))
            out.append((Summary.from_dict(document["decision_inputs"]), effects))
    return out


def scored(cases: list[Case], samples: float) -> list[tuple[float, bool]]:
    """Each verdict's confidence at ``samples`` and whether it was right."""
    out = []
    for summary, truth in cases:
        verdict = decide(summary)
        share = posterior(summary, samples).of(verdict.effects)
        if verdict.capped is not None:
            share = min(share, _confidence(STAND_IN_MARGIN))
        out.append((share, sorted(verdict.effects) == truth))
    return out


def log_loss(rows: list[tuple[float, bool]]) -> float:
    """Mean negative log-likelihood of right/wrong under the confidences."""
    terms = [math.log(min(max(p if ok else 1.0 - p, 1e-9), 1.0)) for p, ok in rows]
    return -sum(terms) / max(len(terms), 1)


def table(title: str, rows: list[tuple[float, bool]]) -> None:
    """The reliability table (markdown) and the wrong share of sure (>= 0.9) verdicts."""
    right = sum(ok for _, ok in rows)
    print(f"\n{title}: {len(rows)} verdicts, {right} right, log-loss {log_loss(rows):.3f}")
    print("| confidence | verdicts | mean confidence | right |")
    print("|---|---|---|---|")
    for low, high in BINS:
        inside = [(p, ok) for p, ok in rows if low <= p < high]
        if inside:
            mean = sum(p for p, _ in inside) / len(inside)
            hits = sum(ok for _, ok in inside)
            print(f"| {low:.2f}-{min(high, 1.0):.2f} | {len(inside)} | {mean:.2f} | {hits} |")
    sure = [ok for p, ok in rows if p >= 0.9]
    print(f"wrong among sure verdicts (>= 0.9): {len(sure) - sum(sure)} of {len(sure)}")


def main() -> int:
    """Fit on the first set, judge on every set."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sets", nargs="+", help="FIT_SET CHECK_SET ... (see the docstring)")
    args = parser.parse_args()
    sets = {spec: read_set(spec) for spec in args.sets}
    fit_on = args.sets[0]
    losses = {n: log_loss(scored(sets[fit_on], n)) for n in GRID}
    fitted = min(losses, key=lambda n: losses[n])
    print("log-loss on the fit set: " + ", ".join(f"{n:g}: {v:.3f}" for n, v in losses.items()))
    print(f"fitted EFFECTIVE_SAMPLES {fitted:g} (shipped {EFFECTIVE_SAMPLES:g})")
    for spec, cases in sets.items():
        role = "fit set" if spec == fit_on else "check set"
        table(f"{spec} ({role}), shipped {EFFECTIVE_SAMPLES:g}", scored(cases, EFFECTIVE_SAMPLES))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
