"""``brake-hil trend``: each rig's calibrated values and effects across its stored diagnoses.

Reads the results database (:mod:`brake_hil.results.store`), trends every rig's diagnoses in
time order (:mod:`brake_hil.results.trend`) and writes ``trend.html`` with a figure per rig
(:mod:`brake_hil.report.trend_report`) into the output folder (default: ``trend/`` beside the
database file; for a PostgreSQL database, ``trend/`` in the working directory).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from brake_hil.app.regress import bag_key, load_baseline
from brake_hil.errors import BrakeHilError
from brake_hil.files import check_output_folder
from brake_hil.report.trend_report import write_trend_report
from brake_hil.results.metrics_trend import RecordingTrend, Reference, metrics_trends
from brake_hil.results.store import open_store
from brake_hil.results.trend import RigTrend, trends

__all__ = ["TrendResult", "default_output", "run_trend"]


@dataclass(frozen=True)
class TrendResult:
    """What :func:`run_trend` found and wrote.

    Attributes:
        database: the results database read (its file, or its URL with the password masked).
        rigs: one trend per rig, sorted by rig name.
        report_path: ``trend.html``.
        recordings: the regressions' and comparisons' trends, one per recording.
    """

    database: str
    rigs: tuple[RigTrend, ...]
    report_path: Path
    recordings: tuple[RecordingTrend, ...] = ()


def default_output(database: Path | None) -> Path:
    """``trend/`` beside the database file; for a server's database (``None``), here."""
    return database.parent / "trend" if database is not None else Path("trend")


def run_trend(
    database: str | Path,
    rig: str | None = None,
    out: Path | None = None,
    baseline: Path | None = None,
) -> TrendResult:
    """Trend the stored diagnoses and the regressions and comparisons; write the report.

    Every rig's diagnoses (or ``rig``'s) and every recording's regressions and comparisons.

    Args:
        database: the results database (a path, ``sqlite:///path`` or
            ``postgresql://...``); it must exist.
        rig: only this rig name (``None``: every rig).
        out: the report's folder (``None``: :func:`default_output`).
        baseline: a ``regress`` baseline JSON: its values and tolerances are the reference
            of the regressions' metrics (``None``: each recording's first run, the default
            tolerances).

    Raises:
        BrakeHilError: the database is missing, not a results database, or holds no
            diagnosis, regression or comparison (of ``rig``); an unreadable baseline.
        OutputError: the output folder cannot be written.
    """
    reference, tolerances = _baseline(baseline) if baseline is not None else (None, None)
    with open_store(database, create=False) as store:
        rows = store.diagnoses(rig)
        replays = store.metrics_runs(rig)
        known = sorted({*store.rigs(), *(run.rig_name for run in store.metrics_runs())})
        name, path = store.name, store.path
    if not rows and not replays:
        listed = ", ".join(repr(name) for name in known) or "none"
        what = f"of rig {rig!r} " if rig is not None else ""
        raise BrakeHilError(
            f"{name}: no diagnosis, regression or comparison {what}stored (rigs: {listed})"
        )
    folder = check_output_folder(out if out is not None else default_output(path))
    rigs = tuple(trends(rows)) if rows else ()
    recordings = tuple(metrics_trends(replays, reference, tolerances))
    page = write_trend_report(rigs, folder, name, recordings)
    return TrendResult(name, rigs, page, recordings)


def _baseline(path: Path) -> tuple[Reference, dict[str, float]]:
    """A baseline's metrics by recording path, and its tolerances."""
    document = load_baseline(path)
    bags = document["bags"]

    def reference(recording: str) -> dict[str, dict[str, float]] | None:
        entry = bags.get(bag_key(recording, path))
        return None if entry is None else entry["metrics"]

    return reference, {k: float(v) for k, v in document.get("tolerances", {}).items()}
