"""``brake-hil cases``: the concealed-effect benchmark set, simulated in parallel.

:mod:`brake_hil.virtual_rig.cases` describes the cases and simulates one;
:func:`generate_cases` maps that over the described cases with
:func:`~brake_hil.app.parallel.parallel_map` and writes the labels apart from the recordings.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

from brake_hil.app.parallel import SERIAL, Outcome, Workers, parallel_map, values
from brake_hil.errors import BrakeHilError
from brake_hil.virtual_rig.cases import (
    SEED_DRIVE,
    CaseDrive,
    make_case,
    select_cases,
    write_labels,
)
from brake_hil.virtual_rig.excitation import EXCITATION_KINDS

__all__ = ["CaseOptions", "CasesResult", "generate_cases", "run_cases"]


@dataclass(frozen=True)
class CaseOptions:
    """What the cases are made of, besides their number and seed.

    Attributes:
        pulsing_s: seconds of 5 Hz pulsing per maximum pressure (5 s: 18 s recordings).
        error_scale: multiplies the one-sigma tolerances the parameter errors are drawn from.
        kinds: keep only cases of these kinds (null, single, pair, unexplained,
            out_of_tolerance, more_air), numbered as in the full schedule; the count is then
            the number kept (empty: every kind).
        family: the family of truth laws (``a``, the registered laws, ``b`` or ``c``; see
            :mod:`brake_hil.virtual_rig.cases`).
        drive: the pulsing frequency, maximum pressures and excitation (default: the
            paper's pulsing; a ``sweep``, ``ramp`` or ``procedure`` instead, see
            :func:`~brake_hil.virtual_rig.excitation.named_excitation`).
        span: how the truth rigs differ from their files: ``contract`` (every toleranced
            value uniform within its tolerance, the new kinds mixed in) or ``seed`` (the
            stored sets' draw, to replay them); see :mod:`brake_hil.virtual_rig.draws`.
    """

    pulsing_s: float = 5.0
    error_scale: float = 1.0
    kinds: tuple[str, ...] = ()
    family: str = "a"
    drive: CaseDrive = SEED_DRIVE
    span: str = "contract"


def generate_cases(
    out: Path | str,
    count: int,
    seed: int = 0,
    options: CaseOptions = CaseOptions(),
    *,
    workers: Workers = SERIAL,
    progress: Callable[[int, int, int], None] | None = None,
) -> Path:
    """Write ``count`` labelled cases under ``out``; return the path of ``labels.json``.

    Args:
        out: a new or empty directory; gets ``cases/NNN/{recording/,rig.yaml}`` and
            ``labels.json``.
        count: number of cases (with ``options.kinds``, the number kept).
        seed: seed of every draw (cases, strengths, parameter errors, sensor noise).
        options: the pulsing, parameter errors, kinds, family and drive of the cases.
        workers: where the cases are simulated (:class:`~brake_hil.app.parallel.Workers`).
        progress: called with the number of cases written, failed and in all: once before
            the first is simulated, then as each finishes (in the order they finish).

    Raises:
        FileExistsError: ``out`` holds files already.
        EffectError: an unknown family or span, or a kind the span never makes (before
            anything is written).
        BrakeHilError: a case could not be simulated (the first such, after every case ran;
            no ``labels.json`` is written then).
    """
    out = Path(out)
    if out.exists() and any(out.iterdir()):
        raise FileExistsError(f"{out}: not empty; choose a new directory for the cases")
    specs = select_cases(
        count,
        seed,
        options.kinds,
        error_scale=options.error_scale,
        family=options.family,
        span=options.span,
    )
    cases_dir = out / "cases"
    cases_dir.mkdir(parents=True, exist_ok=True)

    written = failed = 0

    def report(outcome: Outcome[dict[str, Any]]) -> None:
        nonlocal written, failed
        written += outcome.ok
        failed += not outcome.ok
        if progress is not None:
            progress(written, failed, len(specs))

    if progress is not None:
        progress(0, 0, len(specs))
    simulate = partial(
        make_case, cases_dir=cases_dir, pulsing_s=options.pulsing_s, drive=options.drive
    )
    made = values(parallel_map(simulate, specs, workers, report))
    labels = {spec.case_id: label for spec, label in zip(specs, made)}
    return write_labels(
        out,
        labels,
        count=count,
        seed=seed,
        pulsing_s=options.pulsing_s,
        error_scale=options.error_scale,
        kinds=options.kinds,
        family=options.family,
        drive=options.drive,
        span=options.span,
    )


@dataclass(frozen=True)
class CasesResult:
    """The benchmark set written."""

    count: int
    cases_dir: Path  # DIR/cases, one folder per case
    labels_path: Path  # DIR/labels.json


def run_cases(
    out: Path,
    count: int,
    seed: int = 0,
    options: CaseOptions = CaseOptions(),
    *,
    workers: Workers = SERIAL,
    progress: Callable[[int, int, int], None] | None = None,
) -> CasesResult:
    """``brake-hil cases``: check the options, then :func:`generate_cases`.

    Args:
        out: a new or empty directory.
        count: number of cases (at least 1).
        seed: seed of every draw.
        options: the cases' pulsing (above 0 s) and drive: the pulsing frequency (0.5-20 Hz)
            and maximum pressures (2-5 of them, increasing, 0.3-10 MPa); their parameter
            errors, kinds and family (see :class:`CaseOptions`).
        workers: where the cases are simulated.
        progress: called with the cases written, failed and in all (see
            :func:`generate_cases`).

    Returns:
        Where the cases and the labels are.

    Raises:
        BrakeHilError: a bad option, or ``out`` is not a new or empty directory.
    """
    if count < 1 or options.pulsing_s <= 0.0:
        raise BrakeHilError("cases: --count must be >= 1, --pulsing-seconds > 0")
    hz, pressures = options.drive.excitation_hz, options.drive.max_pressures
    if hz is not None and not 0.5 <= hz <= 20.0:
        raise BrakeHilError(f"cases: --excitation-hz {hz:g} is outside 0.5-20 Hz")
    if not (
        2 <= len(pressures) <= 5
        and all(0.3e6 <= p <= 10e6 for p in pressures)
        and all(b > a for a, b in zip(pressures, pressures[1:]))
    ):
        shown = ",".join(f"{p / 1e6:g}" for p in pressures)
        raise BrakeHilError(
            f"cases: --max-pressures {shown}: give 2-5 increasing pressures of 0.3-10 MPa"
        )
    if options.drive.excitation not in EXCITATION_KINDS:
        raise BrakeHilError(
            f"cases: --excitation {options.drive.excitation}: choose one of "
            f"{', '.join(EXCITATION_KINDS)}"
        )
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise BrakeHilError(f"{out}: not empty; choose a new directory for the cases")
    labels = generate_cases(out, count, seed, options, workers=workers, progress=progress)
    return CasesResult(count, out / "cases", labels)
