"""``brake-hil benchmark``: score the diagnosis blind on labelled concealed-effect cases.

This is the only module of brake_hil that reads labels. It hands the diagnosis each case's
recording and nominal rig file (never the label, the case's name or its metadata), collects
the verdicts, and only then opens the labels to score them:

* top-1 accuracy on single-effect cases (the verdict's first effect is the label) and how
  often the verdict is exactly the label;
* exact-set accuracy on pairs;
* false-positive rate on null cases (parameter error only): any verdict but none, over all
  nulls and split by their air (``degassed``, ``rig_file``; a null with the rig file's air
  that names ``entrained_air`` alone with ``verdict.air.state`` ``as_rig_file`` is right: the
  physics is there and the advice says no bleeding); how often a null's verdict names
  a rig value far outside its tolerance;
* ``unexplained`` recall on cases whose physics no candidate models;
* ``out_of_tolerance`` found: no effect named (or only the rig file's own air, said as the
  rig file's, as on a null: these cases carry it too) and some ``verdict.rig_values[*].keys``
  holds the labelled key (a verdict without ``rig_values`` has not found it);
* ``more_air`` recall: ``verdict.air.state`` is ``more_than_rig_file``; and the same said of
  a null with the rig file's own air (a false alarm);
* held-out RMS improvement on the mismatched channel (baseline / improved, the channel
  with the worst baseline NRMSE) on correctly diagnosed cases;
* seconds per recording, and the confidence's reliability table (per bin of 0.1 from 0.5:
  count, mean confidence, share right), with the count and share of *sure* verdicts
  (confidence ``SURE`` or more) that are wrong.

A verdict is *right* by its case's kind (:func:`is_right`). Every figure but the seconds is
given over all cases and per family of truth laws (``by_family``).

:func:`run_benchmark` is the command: the cases diagnosed over
:func:`~brake_hil.app.parallel.parallel_map`, then scored; it prints nothing and returns a
:class:`Benchmark`. With ``keep`` it also writes each case's ``diagnosis.json`` (its
``decision_inputs`` let a confidence be recalibrated later without diagnosing again).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from functools import partial
import json
from pathlib import Path
import statistics
import time
import traceback

from brake_hil.app.output import check_outputs, write_json
from brake_hil.app.parallel import SERIAL, Outcome, Workers, parallel_map, values
from brake_hil.diagnosis.diagnose import diagnose
from brake_hil.diagnosis.rig_findings import AIR_EFFECT
from brake_hil.errors import BrakeHilError
from brake_hil.files import output_file
from brake_hil.io.opened import open_recording

CONFIDENCE_BINS = ((0.0, 0.5), (0.5, 0.6), (0.6, 0.7), (0.7, 0.8), (0.8, 0.9), (0.9, 1.01))
"""The reliability table's bins (the last holds 1.0)."""
KINDS = ("null", "single", "pair", "unexplained", "out_of_tolerance", "more_air")
"""The kinds of case ``brake-hil cases`` labels (:mod:`brake_hil.virtual_rig.cases`)."""
NULL_AIRS = ("degassed", "rig_file")
"""The air of a null case's rig: none (degassed) or the rig file's own."""
MORE_AIR = "more_than_rig_file"
"""``verdict.air.state`` when the diagnosis finds more air than the rig file says."""
AS_RIG_FILE = "as_rig_file"
"""``verdict.air.state`` when the air named is the rig file's own (no bleeding)."""
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
    baseline_rms: dict[str, float]
    improved_rms: dict[str, float]
    error: str = ""
    improvements: dict[str, float] = field(default_factory=dict)  # hypothesis -> ratio
    summary: dict[str, object] = field(default_factory=dict)  # the decision's inputs
    verdict: dict[str, object] = field(default_factory=dict)  # diagnosis.json's verdict


def diagnose_case(case_dir: Path, keep: Path | None = None) -> CaseResult:
    """Diagnose ``case_dir/recording`` against ``case_dir/rig.yaml``; nothing else is read.

    ``keep``: write the case's ``diagnosis.json`` to ``keep/<case>/diagnosis.json``.
    """
    began = time.perf_counter()

    def failed(error: str) -> CaseResult:
        return CaseResult(case_dir.name, (), 0.0, time.perf_counter() - began, {}, {}, error)

    try:
        opened = open_recording(case_dir / "recording", case_dir / "rig.yaml")
        result = diagnose(opened.recording, opened.rig)
        document = result.as_dict()
        if keep is not None:
            write_json(output_file(keep / case_dir.name, "diagnosis.json"), document)
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
        baseline_rms=result.baseline.held_out_rms,
        improved_rms=result.improved.held_out_rms,
        improvements={
            "+".join(h.effects): result.baseline.held_out_cost / max(h.held_out_cost, 1e-15)
            for h in result.hypotheses
        },
        summary=result.summary.as_dict(),
        verdict=dict(document["verdict"]),  # type: ignore[call-overload]
    )


def run_cases(
    case_dirs: Iterable[Path],
    workers: Workers = SERIAL,
    progress: Callable[[CaseResult], None] | None = None,
    keep: Path | None = None,
) -> list[CaseResult]:
    """Diagnose every case (sorted by folder) where ``workers`` says.

    Args:
        case_dirs: case folders, each with ``recording/`` and ``rig.yaml``.
        workers: where the cases are diagnosed (:class:`~brake_hil.app.parallel.Workers`).
        progress: called with each case's result as it comes in (in the order they finish).
        keep: a folder for each case's ``diagnosis.json`` (``None``: none written).

    Returns:
        One result per case, in order; a case whose input is refused carries its error.
    """

    def report(outcome: Outcome[CaseResult]) -> None:
        if progress is not None and outcome.value is not None:
            progress(outcome.value)

    diagnosed = partial(diagnose_case, keep=keep)
    return values(parallel_map(diagnosed, sorted(case_dirs), workers, report))


def read_labels(path: Path) -> dict[str, list[str]]:
    """Labels ``{case: [effect, ...]}`` (``[]`` for a null case, ``["unexplained"]``).

    Reads ``brake-hil cases``'s ``labels.json`` (``{"cases": {case: {"expected_effects":
    [...]}}}``) or a plain ``{case: {"effects": [...]}}``.
    """
    return {
        case: [str(e) for e in entry["expected_effects"]]  # type: ignore[attr-defined]
        for case, entry in read_case_labels(path).items()
    }


def read_case_labels(path: Path) -> dict[str, dict[str, object]]:
    """Each case's label: its ``expected_effects`` and kind, and whatever else it carries.

    The kind is the label's own, or, for labels without one, read from the effects (none:
    ``null``; ``unexplained``; one: ``single``; more: ``pair``).

    Raises:
        BrakeHilError: the file cannot be read or holds no labels of this shape.
    """
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
        entries = document.get("cases", document)
        labels = {}
        for case, entry in entries.items():
            effects = [str(e) for e in entry.get("expected_effects", entry.get("effects"))]
            labels[str(case)] = {**entry, "expected_effects": effects}
    except (OSError, json.JSONDecodeError, AttributeError, TypeError) as err:
        raise BrakeHilError(f"{path}: cannot read labels: {err}") from err
    return {case: {**entry, "kind": case_kind(entry)} for case, entry in labels.items()}


def case_kind(label: Mapping[str, object]) -> str:
    """The kind of a case from its label (see :func:`read_case_labels`)."""
    kind = label.get("kind")
    if isinstance(kind, str) and kind in KINDS:
        return kind
    effects = list(label.get("expected_effects", ()))  # type: ignore[call-overload]
    if effects == ["unexplained"]:
        return "unexplained"
    return ("null", "single")[len(effects)] if len(effects) < 2 else "pair"


def score(
    results: list[CaseResult], labels: Mapping[str, Sequence[str] | Mapping[str, object]]
) -> dict[str, object]:
    """The benchmark's figures (see the module docstring), over all and per family.

    ``labels``: per case, :func:`read_case_labels`'s label or just its expected effects.
    """
    entries = {case: _as_label(label) for case, label in labels.items()}
    items = [(r, entries[r.case]) for r in results]
    seconds = [r.seconds for r in results]
    families = sorted({str(label.get("family", "")) for _, label in items} - {""})
    return {
        "cases": len(results),
        **family_figures(items),
        "seconds_per_recording_mean": statistics.fmean(seconds) if seconds else float("nan"),
        "seconds_per_recording_max": max(seconds) if seconds else float("nan"),
        "by_family": {
            family: family_figures([(r, lab) for r, lab in items if lab.get("family") == family])
            for family in families
        },
        "errors": [r.case + ": " + r.error for r in results if r.error],
        "per_case": [
            {
                **asdict(r),
                "label": entries[r.case]["expected_effects"],
                "kind": entries[r.case]["kind"],
            }
            for r in results
        ],
    }


Scored = tuple["CaseResult", Mapping[str, object]]


def _as_label(label: Sequence[str] | Mapping[str, object]) -> dict[str, object]:
    if isinstance(label, Mapping):
        entry = {**label, "expected_effects": list(label.get("expected_effects", ()))}  # type: ignore[call-overload]
    else:
        entry = {"expected_effects": list(label)}
    return {**entry, "kind": case_kind(entry)}


def _share(
    items: Sequence[Scored], test: Callable[[CaseResult, Mapping[str, object]], bool]
) -> float:
    return sum(test(r, lab) for r, lab in items) / len(items) if items else float("nan")


def _air_state(result: CaseResult) -> str:
    air = result.verdict.get("air")
    return str(air.get("state", "")) if isinstance(air, Mapping) else ""


def _rig_value_keys(result: CaseResult) -> set[str]:
    """Every dotted key named by the verdict's ``rig_values`` (none when it has no such field)."""
    entries = result.verdict.get("rig_values")
    if not isinstance(entries, list):
        return set()
    return {
        str(key)
        for entry in entries
        if isinstance(entry, Mapping) and isinstance(entry.get("keys"), list)
        for key in entry["keys"]
    }


def _air_as_rig_file(result: CaseResult, label: Mapping[str, object]) -> bool:
    """A case with the rig file's own air (a null, an out-of-tolerance one) named it so.

    Named alone, as the rig file's (no bleeding): the physics is there (the air's compliance
    follows the pressure, which the LTI model linearises) and ``verdict.air`` says it is the
    rig file's: right, not a false positive.
    """
    return (
        label["kind"] in ("null", "out_of_tolerance")
        and label.get("air") == "rig_file"
        and tuple(result.effects) == (AIR_EFFECT,)
        and _air_state(result) == AS_RIG_FILE
    )


def is_right(result: CaseResult, label: Mapping[str, object]) -> bool:
    """Whether the verdict is right for the case's kind (see the module docstring)."""
    kind = label["kind"]
    if kind == "out_of_tolerance":
        alone = not result.effects or _air_as_rig_file(result, label)
        return alone and str(label.get("key")) in _rig_value_keys(result)
    if kind == "more_air":
        return _air_state(result) == MORE_AIR
    if _air_as_rig_file(result, label):
        return True
    expected: Sequence[str] = label["expected_effects"]  # type: ignore[assignment]
    return set(result.effects) == set(expected)


def family_figures(items: Sequence[Scored]) -> dict[str, object]:
    """The Done-when figures over ``items`` (one family's cases, or all)."""
    of = {kind: [(r, lab) for r, lab in items if lab["kind"] == kind] for kind in KINDS}
    singles, pairs, nulls = of["single"], of["pair"], of["null"]
    by_air = {air: [(r, lab) for r, lab in nulls if lab.get("air") == air] for air in NULL_AIRS}
    improvements = []
    for result, label in singles + pairs:
        if is_right(result, label) and result.improved_rms:
            worst = max(result.baseline_rms, key=lambda k: result.baseline_rms[k])
            improvements.append(
                result.baseline_rms[worst] / max(result.improved_rms[worst], 1e-12)
            )
    sure = [(r, lab) for r, lab in items if r.confidence >= SURE and not r.error]
    wrong_sure = [r.case for r, lab in sure if not is_right(r, lab)]
    named = lambda r, lab: bool(r.effects) and not _air_as_rig_file(r, lab)  # noqa: E731
    return {
        "single_effect_cases": len(singles),
        "top1_accuracy_single": _share(
            singles,
            lambda r, lab: bool(r.effects) and r.effects[0] == lab["expected_effects"][0],  # type: ignore[index]
        ),
        "exact_accuracy_single": _share(singles, is_right),
        "pair_cases": len(pairs),
        "exact_set_accuracy_pairs": _share(pairs, is_right),
        "null_cases": len(nulls),
        "false_positive_rate_null": _share(nulls, named),
        **{f"null_cases_{air}": len(by_air[air]) for air in NULL_AIRS},
        **{f"false_positive_rate_null_{air}": _share(by_air[air], named) for air in NULL_AIRS},
        "null_rig_value_alarm_rate": _share(nulls, lambda r, lab: bool(_rig_value_keys(r))),
        "unexplained_cases": len(of["unexplained"]),
        "unexplained_recall": _share(
            of["unexplained"], lambda r, lab: r.effects == ("unexplained",)
        ),
        "out_of_tolerance_cases": len(of["out_of_tolerance"]),
        "out_of_tolerance_found": _share(of["out_of_tolerance"], is_right),
        "more_air_cases": len(of["more_air"]),
        "more_air_recall": _share(of["more_air"], is_right),
        "more_air_false_alarm_rate_rig_file_nulls": _share(
            by_air["rig_file"], lambda r, lab: _air_state(r) == MORE_AIR
        ),
        "held_out_rms_improvement_median": (
            statistics.median(improvements) if improvements else float("nan")
        ),
        "held_out_rms_improvement_at_least_3x": (
            sum(i >= 3.0 for i in improvements) / len(improvements)
            if improvements
            else float("nan")
        ),
        "reliability": reliability(items),
        "sure_verdicts": len(sure),
        "wrong_sure_count": len(wrong_sure),
        "wrong_sure_verdicts": wrong_sure,
        "wrong_share_of_sure_verdicts": len(wrong_sure) / len(sure) if sure else float("nan"),
    }


def reliability(items: Sequence[Scored]) -> list[dict[str, object]]:
    """The reliability table: per ``CONFIDENCE_BINS`` bin holding a verdict, its count.

    And the verdicts' mean confidence and share right (:func:`is_right`).
    """
    rows: list[dict[str, object]] = []
    for low, high in CONFIDENCE_BINS:
        inside = [(r, lab) for r, lab in items if low <= r.confidence < high]
        if inside:
            rows.append(
                {
                    "confidence": [low, min(high, 1.0)],
                    "cases": len(inside),
                    "mean_confidence": statistics.fmean(r.confidence for r, _ in inside),
                    "accuracy": _share(inside, is_right),
                }
            )
    return rows


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
    keep: Path | None = None,
) -> Benchmark:
    """``brake-hil benchmark``: the diagnosis, blind, on every case of a set.

    Diagnoses ``DIR/cases`` and scores on ``DIR/labels.json`` only after every verdict is in.

    Args:
        directory: made by ``brake-hil cases`` (``cases/NNN/`` and ``labels.json``).
        workers: where the cases are diagnosed.
        json_path: write the figures here as JSON (``None``: nowhere).
        progress: called with each case's result as it comes in (in the order they finish).
        keep: write each case's ``diagnosis.json`` under ``keep/<case>/`` (a new or empty
            folder; ``None``: nowhere).

    Returns:
        The verdicts and the figures.

    Raises:
        BrakeHilError: no cases, no labels, labels that cannot be read, or a ``keep``
            folder that holds files already.
    """
    check_outputs(json_path)
    if keep is not None and (keep.is_file() or (keep.is_dir() and any(keep.iterdir()))):
        raise BrakeHilError(f"{keep}: not empty; choose a new folder for the diagnoses")
    cases = sorted(p for p in (directory / "cases").glob("*") if p.is_dir())
    if not cases:
        raise BrakeHilError(f"{directory}: no cases under {directory / 'cases'}")
    labels_path = directory / "labels.json"
    if not labels_path.exists():
        raise BrakeHilError(f"{labels_path}: no labels to score against")
    labels = read_case_labels(labels_path)
    results = run_cases(cases, workers, progress, keep)
    figures = score(results, labels)
    write_json(json_path, figures)
    return Benchmark(tuple(results), figures, json_path)
