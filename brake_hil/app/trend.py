"""``brake-hil trend``: each rig's calibrated values and effects across its stored diagnoses.

Reads the results database (:mod:`brake_hil.results.store`), trends every rig's diagnoses in
time order (:mod:`brake_hil.results.trend`) and writes ``trend.html`` with a figure per rig
(:mod:`brake_hil.report.trend_report`) into the output folder (default: ``trend/`` beside the
database).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from brake_hil.errors import BrakeHilError
from brake_hil.files import check_output_folder
from brake_hil.report.trend_report import write_trend_report
from brake_hil.results.store import database_path, open_store
from brake_hil.results.trend import RigTrend, trends

__all__ = ["TrendResult", "default_output", "run_trend"]


@dataclass(frozen=True)
class TrendResult:
    """What :func:`run_trend` found and wrote.

    Attributes:
        database: the results database read.
        rigs: one trend per rig, sorted by rig name.
        report_path: ``trend.html``.
    """

    database: Path
    rigs: tuple[RigTrend, ...]
    report_path: Path


def default_output(database: Path) -> Path:
    """``trend/`` beside the database file."""
    return database.parent / "trend"


def run_trend(
    database: str | Path, rig: str | None = None, out: Path | None = None
) -> TrendResult:
    """Trend the stored diagnoses of every rig (or of ``rig``) and write the report.

    Args:
        database: the results database (a path or ``sqlite:///path``); it must exist.
        rig: only this rig name (``None``: every rig).
        out: the report's folder (``None``: :func:`default_output`).

    Raises:
        BrakeHilError: the database is missing, not a results database, or holds no
            diagnosis (of ``rig``).
        OutputError: the output folder cannot be written.
    """
    path = database_path(database)
    with open_store(path, create=False) as store:
        rows = store.diagnoses(rig)
        known = store.rigs()
    if not rows:
        listed = ", ".join(repr(name) for name in known) or "none"
        what = f"of rig {rig!r} " if rig is not None else ""
        raise BrakeHilError(f"{path}: no diagnosis {what}stored (rigs: {listed})")
    folder = check_output_folder(out if out is not None else default_output(path))
    rigs = tuple(trends(rows))
    return TrendResult(path, rigs, write_trend_report(rigs, folder, path))
