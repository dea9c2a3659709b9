"""Verdicts kept by ``brake-hil benchmark --keep``, before and after the geometry fold.

Each kept ``diagnosis.json`` of a decision made without the fold (``decision_inputs.geometry``
empty) is replayed: the fitted share of every ``eccentric_load`` hypothesis (its
``hypotheses`` entry) is judged against the band of its case's rig file at the case's
recorded bore pressures (``geometry_share``), the stand-ins are folded (``fold_geometry``)
and ``decide`` runs again. The physics checks are not run again: the stored stand-ins stay.

    python3 benchmarks/bench_geometry_share.py KEEP CASES [--all]

``CASES`` is the ``brake-hil cases`` folder (its ``labels.json``, ``cases/NNN/``). Prints the
cases whose verdict changes or names ``eccentric_load`` (``--all``: every case), then per set:
cases right, top-1 on singles, null false positives, wrong at >= 0.9, ``eccentric_load``
named (and where the truth has none).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
import sys

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from brake_hil.app.benchmark import SURE, CaseResult, is_right, read_case_labels  # noqa: E402
from brake_hil.diagnosis.candidates.eccentric_load import geometry_share  # noqa: E402
from brake_hil.diagnosis.dataset import prepare  # noqa: E402
from brake_hil.diagnosis.geometry_share import (  # noqa: E402
    ECCENTRIC,
    fold_geometry,
    recorded_pressures,
)
from brake_hil.diagnosis.summary import Summary  # noqa: E402
from brake_hil.diagnosis.tolerance_prior import share_band  # noqa: E402
from brake_hil.diagnosis.verdict import decide  # noqa: E402
from brake_hil.io.opened import open_recording  # noqa: E402

SHARE = ("share_offset", "share_slope", "share_curvature")
Scored = tuple[CaseResult, dict[str, object]]


def replay(case: Path, document: dict[str, object]) -> CaseResult:
    """The case's verdict with its geometry stand-ins folded."""
    opened = open_recording(case / "recording", case / "rig.yaml")
    pressures = recorded_pressures(prepare(opened.recording, opened.rig))
    band = share_band(opened.rig)
    stand_ins = {}
    for h in document["hypotheses"]:  # type: ignore[attr-defined]
        if ECCENTRIC in h["effect"].split("+"):
            theta = np.array([h["parameters"][k] for k in SHARE])
            why = geometry_share(theta, band, pressures)
            if why is not None:
                stand_ins[h["effect"]] = why
    summary = Summary.from_dict(document["decision_inputs"])  # type: ignore[arg-type]
    verdict = decide(fold_geometry(summary, stand_ins))
    stored = dict(document["verdict"])  # type: ignore[call-overload]
    return CaseResult(case.name, verdict.effects, verdict.confidence, 0.0, {}, {}, verdict=stored)


def figures(items: list[Scored]) -> str:
    """The set's figures in one line."""
    singles = [(r, lab) for r, lab in items if lab["kind"] == "single"]
    nulls = [(r, lab) for r, lab in items if lab["kind"] == "null"]
    top1 = sum(
        bool(r.effects) and r.effects[0] == lab["expected_effects"][0] for r, lab in singles
    )  # type: ignore[index]
    sure = [(r, lab) for r, lab in items if r.confidence >= SURE]
    wrong = [r.case for r, lab in sure if not is_right(r, lab)]
    named = [(r, lab) for r, lab in items if ECCENTRIC in r.effects]
    spurious = [r for r, lab in named if ECCENTRIC not in lab["expected_effects"]]  # type: ignore[operator]
    return (
        f"right {sum(is_right(r, lab) for r, lab in items)}/{len(items)}, top-1 {top1}/"
        f"{len(singles)}, null false positives {sum(not is_right(r, lab) for r, lab in nulls)}/"
        f"{len(nulls)}, wrong at >= {SURE:g} {len(wrong)}/{len(sure)} {wrong}, "
        f"eccentric_load named {len(named)} (not in the truth {len(spurious)})"
    )


def main() -> None:
    """Replay every kept case; print the changes and the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("keep", type=Path)
    parser.add_argument("cases", type=Path)
    parser.add_argument("--all", action="store_true")
    args = parser.parse_args()
    labels = read_case_labels(args.cases / "labels.json")
    before: list[Scored] = []
    after: list[Scored] = []
    for folder in sorted(p for p in args.keep.iterdir() if (p / "diagnosis.json").is_file()):
        document = json.loads((folder / "diagnosis.json").read_text(encoding="utf-8"))
        label = labels[folder.name]
        stored = document["verdict"]
        old = CaseResult(
            folder.name, tuple(stored["effects"]), stored["confidence"], 0.0, {}, {},
            verdict=stored,
        )  # fmt: skip
        new = replay(args.cases / "cases" / folder.name, document)
        before.append((old, label))
        after.append((new, label))
        if args.all or old.effects != new.effects or ECCENTRIC in old.effects + new.effects:
            print(
                f"{folder.name} {label['kind']} {list(label['expected_effects'])}: "  # type: ignore[call-overload]
                f"{list(old.effects)} {old.confidence:.2f} -> "
                f"{list(new.effects)} {new.confidence:.2f}"
            )
    print(f"before: {figures(before)}")
    print(f"after: {figures(after)}")


if __name__ == "__main__":
    main()
