"""``brake-hil benchmark``: score the diagnosis blind on labelled concealed-effect cases.

This is the only module of brake_hil that reads labels. It hands the diagnosis each case's
recording and nominal rig file (never the label, the case's name or its metadata), collects
the verdicts, and only then opens the labels to score them:

* top-1 accuracy on single-effect cases (the verdict's first effect is the label) and how
  often the verdict is exactly the label;
* exact-set accuracy on pairs;
* false-positive rate on null cases (parameter error only): any verdict but none;
* ``unexplained`` recall on cases whose physics no candidate models;
* held-out NRMSE improvement on the mismatched channel (baseline / improved, the channel
  with the worst baseline NRMSE) on correctly diagnosed cases;
* seconds per recording, and the confidence's reliability (accuracy per confidence bin),
  with the share of *sure* verdicts (confidence ``SURE`` or more) that are wrong.

:func:`run_benchmark` is the command: the cases diagnosed over
:func:`~brake_hil.app.parallel.parallel_map`, then scored; it prints nothing and returns a
:class:`Benchmark`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import asdict, dataclass, field
import json
from pathlib import Path
import statistics
import time
import traceback

from brake_hil.app.output import check_outputs, write_json
from brake_hil.app.parallel import SERIAL, Outcome, Workers, parallel_map, values
from brake_hil.diagnosis.diagnose import diagnose
from brake_hil.errors import BrakeHilError
from brake_hil.io.opened import open_recording

CONFIDENCE_BINS = ((0.0, 0.5), (0.5, 0.7), (0.7, 0.8), (0.8, 0.9), (0.9, 0.95), (0.95, 1.01))
INTERNAL_ERROR = "internal error"
"""How a case's error starts when the diagnosis itself failed on it (a bug, not its input):
the case is scored as the verdict none and the run goes on; ``brake-hil benchmark`` then
exits 1."""
SURE = 0.9
"""A verdict at this confidence or more is *sure*: at most 1 in 20 of them may be wrong."""


@dataclass(frozen=True)
class CaseResult:
    """The diagnosis of one case, before its label is read."""

    case: str
    effects: tuple[str, ...]
    confidence: float
    seconds: float
    baseline_nrmse: dict[str, float]
    improved_nrmse: dict[str, float]
    error: str = ""
    improvements: dict[str, float] = field(default_factory=dict)  # hypothesis -> ratio
    summary: dict[str, object] = field(default_factory=dict)  # the decision's inputs


def diagnose_case(case_dir: Path) -> CaseResult:
    """Diagnose ``case_dir/recording`` against ``case_dir/rig.yaml``; nothing else is read."""
    began = time.perf_counter()

    def failed(error: str) -> CaseResult:
        return CaseResult(case_dir.name, (), 0.0, time.perf_counter() - began, {}, {}, error)

    try:
        opened = open_recording(case_dir / "recording", case_dir / "rig.yaml")
        result = diagnose(opened.recording, opened.rig)
    except BrakeHilError as err:
        return failed(str(err))
    except Exception as err:  # a bug of the diagnosis: this case's, the others still count
        where = traceback.extract_tb(err.__traceback__)[-1]
        return failed(
            f"{INTERNAL_ERROR}: {type(err).__name__}: {err} "
            f"({Path(where.filename).name}:{where.lineno})"
        )
    return CaseResult(
        case=case_dir.name,
        effects=result.effects,
        confidence=result.confidence,
        seconds=time.perf_counter() - began,
        baseline_nrmse=result.baseline.held_out_nrmse,
        improved_nrmse=result.improved.held_out_nrmse,
        improvements={
            "+".join(h.effects): result.baseline.held_out_cost / max(h.held_out_cost, 1e-15)
            for h in result.hypotheses
        },
        summary=result.summary.as_dict(),
    )


def run_cases(
    case_dirs: Iterable[Path],
    workers: Workers = SERIAL,
    progress: Callable[[CaseResult], None] | None = None,
) -> list[CaseResult]:
    """Diagnose every case (sorted by folder) where ``workers`` says.

    Args:
        case_dirs: case folders, each with ``recording/`` and ``rig.yaml``.
        workers: where the cases are diagnosed (:class:`~brake_hil.app.parallel.Workers`).
        progress: called with each case's result as it comes in (in the order they finish).

    Returns:
        One result per case, in order; a case whose input is refused carries its error.
    """

    def report(outcome: Outcome[CaseResult]) -> None:
        if progress is not None and outcome.value is not None:
            progress(outcome.value)

    return values(parallel_map(diagnose_case, sorted(case_dirs), workers, report))


def read_labels(path: Path) -> dict[str, list[str]]:
    """Labels ``{case: [effect, ...]}`` (``[]`` for a null case, ``["unexplained"]``).

    Reads ``brake-hil cases``'s ``labels.json`` (``{"cases": {case: {"expected_effects":
    [...]}}}``) or a plain ``{case: {"effects": [...]}}``.
    """
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
        entries = document.get("cases", document)
        return {
            str(case): [str(e) for e in entry.get("expected_effects", entry.get("effects"))]
            for case, entry in entries.items()
        }
    except (OSError, json.JSONDecodeError, AttributeError, TypeError) as err:
        raise BrakeHilError(f"{path}: cannot read labels: {err}") from err


def score(results: list[CaseResult], labels: dict[str, list[str]]) -> dict[str, object]:
    """The benchmark's figures (see the module docstring)."""
    singles, pairs, nulls, unexplained = [], [], [], []
    for result in results:
        label = labels[result.case]
        if label == ["unexplained"]:
            unexplained.append((result, label))
        elif not label:
            nulls.append((result, label))
        elif len(label) == 1:
            singles.append((result, label))
        else:
            pairs.append((result, label))

    def share(items: list[tuple[CaseResult, list[str]]], test: Callable[..., bool]) -> float:
        return sum(test(r, lab) for r, lab in items) / len(items) if items else float("nan")

    def correct(result: CaseResult, label: list[str]) -> bool:
        return set(result.effects) == set(label)

    improvements = []
    for result, label in singles + pairs:
        if correct(result, label) and result.improved_nrmse:
            worst = max(result.baseline_nrmse, key=lambda k: result.baseline_nrmse[k])
            improvements.append(
                result.baseline_nrmse[worst] / max(result.improved_nrmse[worst], 1e-12)
            )
    reliability = []
    for low, high in CONFIDENCE_BINS:
        inside = [(r, labels[r.case]) for r in results if low <= r.confidence < high]
        if inside:
            reliability.append(
                {
                    "confidence": [low, min(high, 1.0)],
                    "cases": len(inside),
                    "mean_confidence": statistics.fmean(r.confidence for r, _ in inside),
                    "accuracy": share(inside, correct),
                }
            )
    sure = [(r, labels[r.case]) for r in results if r.confidence >= SURE and not r.error]
    wrong_sure = [r.case for r, lab in sure if not correct(r, lab)]
    seconds = [r.seconds for r in results]
    return {
        "cases": len(results),
        "single_effect_cases": len(singles),
        "top1_accuracy_single": share(
            singles, lambda r, lab: bool(r.effects) and r.effects[0] == lab[0]
        ),
        "exact_accuracy_single": share(singles, correct),
        "pair_cases": len(pairs),
        "exact_set_accuracy_pairs": share(pairs, correct),
        "null_cases": len(nulls),
        "false_positive_rate_null": share(nulls, lambda r, lab: bool(r.effects)),
        "unexplained_cases": len(unexplained),
        "unexplained_recall": share(unexplained, lambda r, lab: r.effects == ("unexplained",)),
        "held_out_nrmse_improvement_median": (
            statistics.median(improvements) if improvements else float("nan")
        ),
        "held_out_nrmse_improvement_at_least_3x": (
            sum(i >= 3.0 for i in improvements) / len(improvements)
            if improvements
            else float("nan")
        ),
        "seconds_per_recording_mean": statistics.fmean(seconds) if seconds else float("nan"),
        "seconds_per_recording_max": max(seconds) if seconds else float("nan"),
        "reliability": reliability,
        "sure_verdicts": len(sure),
        "wrong_sure_verdicts": wrong_sure,
        "wrong_share_of_sure_verdicts": len(wrong_sure) / len(sure) if sure else float("nan"),
        "errors": [r.case + ": " + r.error for r in results if r.error],
        "per_case": [{**asdict(r), "label": labels[r.case]} for r in results],
    }


@dataclass(frozen=True)
class Benchmark:
    """What ``brake-hil benchmark`` found: every verdict, then the figures of :func:`score`."""

    results: tuple[CaseResult, ...]
    figures: dict[str, object]
    json_path: Path | None  # where the figures were written


def case_count(directory: Path) -> int:
    """How many cases ``directory/cases`` holds (0 when none)."""
    return sum(1 for p in (directory / "cases").glob("*") if p.is_dir())


def run_benchmark(
    directory: Path,
    workers: Workers = SERIAL,
    json_path: Path | None = None,
    progress: Callable[[CaseResult], None] | None = None,
) -> Benchmark:
    """``brake-hil benchmark``: the diagnosis, blind, on every case of a set.

    Diagnoses ``DIR/cases`` and scores on ``DIR/labels.json`` only after every verdict is in.

    Args:
        directory: made by ``brake-hil cases`` (``cases/NNN/`` and ``labels.json``).
        workers: where the cases are diagnosed.
        json_path: write the figures here as JSON (``None``: nowhere).
        progress: called with each case's result as it comes in (in the order they finish).

    Returns:
        The verdicts and the figures.

    Raises:
        BrakeHilError: no cases, no labels, or labels that cannot be read.
    """
    check_outputs(json_path)
    cases = sorted(p for p in (directory / "cases").glob("*") if p.is_dir())
    if not cases:
        raise BrakeHilError(f"{directory}: no cases under {directory / 'cases'}")
    labels_path = directory / "labels.json"
    if not labels_path.exists():
        raise BrakeHilError(f"{labels_path}: no labels to score against")
    results = run_cases(cases, workers, progress)
    figures = score(results, read_labels(labels_path))
    write_json(json_path, figures)
    return Benchmark(tuple(results), figures, json_path)
