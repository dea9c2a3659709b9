"""``brake-hil diagnose DIR_OR_GLOB...``: many recordings diagnosed on Dask, results kept.

Each recording is diagnosed by :func:`~brake_hil.app.diagnose.run_diagnose` on a worker
(:func:`~brake_hil.app.parallel.parallel_map`: an embedded Dask ``LocalCluster``, a running
scheduler, or this process), into its own folder under the output folder, mirroring where
the recordings sit (:func:`~brake_hil.app.recordings.mirrored_folder`). Its rig file is
``--rig`` or the one beside it. As each finishes, this process writes its results to the
database (:mod:`brake_hil.results`) in one transaction per recording: a diagnosis, or a
failure with its one-line reason; a recording that fails does not stop the others.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
import json
from pathlib import Path
import time
from typing import Any

from brake_hil.app.parallel import Outcome, Workers, parallel_map
from brake_hil.app.recordings import find_recordings, mirrored_folder, rig_beside
from brake_hil.app.results_db import DATABASE_NAME
from brake_hil.errors import BrakeHilError
from brake_hil.results.identity import RecordingIdentity, identify
from brake_hil.results.store import ResultsStore, open_store

__all__ = [
    "DiagnoseJob",
    "ManyResult",
    "RecordingDiagnosis",
    "diagnose_job",
    "plan_jobs",
    "record_outcome",
    "run_diagnose_many",
]


@dataclass(frozen=True)
class DiagnoseJob:
    """One recording to diagnose: its rig file (``None``: the one beside it) and folder."""

    recording: Path
    rig: Path | None
    out: Path


@dataclass(frozen=True)
class RecordingDiagnosis:
    """What a worker sends back for one recording: its ``diagnosis.json`` and identity."""

    job: DiagnoseJob
    rig: Path
    document: dict[str, Any]
    identity: RecordingIdentity
    seconds: float

    @property
    def effects(self) -> list[str]:
        """The verdict's effects (empty: the calibrated LTI model suffices)."""
        return list(self.document["verdict"]["effects"])

    @property
    def confidence(self) -> float:
        """The verdict's confidence, 0-1."""
        return float(self.document["verdict"]["confidence"])


@dataclass(frozen=True)
class ManyResult:
    """Every recording's outcome, in the recordings' order, and where the results went."""

    outcomes: list[Outcome[RecordingDiagnosis]]
    jobs: list[DiagnoseJob]
    database: str  # its file, or its URL with the password masked
    seconds: float

    @property
    def failed(self) -> list[tuple[DiagnoseJob, str]]:
        """Each failed recording with its one-line reason."""
        return [
            (job, _reason(outcome.error))
            for job, outcome in zip(self.jobs, self.outcomes)
            if outcome.error is not None
        ]


def _reason(error: BaseException | None) -> str:
    text = str(error).strip().splitlines()
    return text[0] if text else type(error).__name__


def plan_jobs(recordings: Sequence[Path], rig: Path | None, out: Path) -> list[DiagnoseJob]:
    """One job per recording, each into its own folder under ``out``."""
    return [
        DiagnoseJob(recording, rig, mirrored_folder(recording, recordings, out))
        for recording in recordings
    ]


def diagnose_job(job: DiagnoseJob) -> RecordingDiagnosis:
    """Diagnose one recording into its folder (on a worker); its document and identity.

    Raises:
        BrakeHilError: a bad recording or rig file, or no rig file beside the recording.
    """
    from brake_hil.app.diagnose import run_diagnose

    began = time.perf_counter()
    rig = job.rig if job.rig is not None else rig_beside(job.recording)
    result = run_diagnose(job.recording, rig, job.out)
    document = json.loads(result.json_path.read_text(encoding="utf-8"))
    return RecordingDiagnosis(
        job, rig, document, identify(job.recording, rig), time.perf_counter() - began
    )


def record_outcome(
    store: ResultsStore, job: DiagnoseJob, outcome: Outcome[RecordingDiagnosis]
) -> None:
    """Write one recording's outcome to ``store``: its diagnosis, or its failure."""
    if outcome.value is not None:
        store.record_diagnosis(outcome.value.identity, outcome.value.document)
    else:
        rig = job.rig
        if rig is None:
            try:
                rig = rig_beside(job.recording)
            except BrakeHilError:
                rig = None
        store.record_failure("diagnosis", job.recording, rig, _reason(outcome.error))


def run_diagnose_many(
    patterns: Sequence[Path | str],
    rig: Path | None,
    out: Path,
    workers: Workers,
    database: Path | str | None = None,
    progress: Callable[[Outcome[RecordingDiagnosis]], None] | None = None,
    on_start: Callable[[int], None] | None = None,
) -> ManyResult:
    """Diagnose every recording ``patterns`` name; write each one's results to the database.

    Args:
        patterns: recordings, folders of recordings, or globs (:func:`find_recordings`).
        rig: one rig file for every recording; ``None``: each recording's own beside it.
        out: output folder; each recording gets a folder under it.
        workers: where the diagnoses run.
        database: results database (path, ``sqlite:///`` or ``postgresql://`` URL); ``None``:
            ``out/results.sqlite``.
        progress: called with each recording's outcome as it finishes.
        on_start: called with the number of recordings before the first is diagnosed.

    Returns:
        The outcomes, in the recordings' order (a failed one carries its error).

    Raises:
        BrakeHilError: a pattern that names no recording, or a database that cannot be opened
            (before any diagnosis runs).
    """
    began = time.perf_counter()
    recordings = find_recordings(patterns)
    jobs = plan_jobs(recordings, rig, out)
    target = database if database is not None else out / DATABASE_NAME
    if database is None:
        out.mkdir(parents=True, exist_ok=True)
    by_index = dict(enumerate(jobs))
    refused: dict[int, Outcome[RecordingDiagnosis]] = {}
    with open_store(target) as store:
        if on_start is not None:
            on_start(len(jobs))

        def finished(outcome: Outcome[RecordingDiagnosis]) -> None:
            try:
                record_outcome(store, by_index[outcome.index], outcome)
            except BrakeHilError as err:  # a diagnosis the store refuses is no result
                outcome = Outcome(outcome.index, error=err)
                refused[outcome.index] = outcome
                record_outcome(store, by_index[outcome.index], outcome)
            if progress is not None:
                progress(outcome)

        outcomes = parallel_map(diagnose_job, jobs, workers, finished)
        database_name = store.name
    outcomes = [refused.get(outcome.index, outcome) for outcome in outcomes]
    return ManyResult(outcomes, jobs, database_name, time.perf_counter() - began)
