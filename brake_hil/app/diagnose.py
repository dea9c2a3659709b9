"""``brake-hil diagnose``: find, name and model the physics the LTI model left out."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from brake_hil.app.naming import naming
from brake_hil.app.output import check_outputs, removed_if_refused, write_json
from brake_hil.diagnosis.candidates import CANDIDATES
from brake_hil.diagnosis.diagnose import PAIR_SHORTLIST, Diagnosis, Progress, diagnose
from brake_hil.files import output_file
from brake_hil.io.opened import open_recording

__all__ = ["DIAGNOSE_FILES", "DIAGNOSIS_STEPS", "DiagnoseResult", "run_diagnose"]

DIAGNOSIS_STEPS = 4 + len(CANDIDATES) + PAIR_SHORTLIST + 1
"""The most steps :func:`run_diagnose` reports: preparing, calibrating, locating, each single
candidate, each pair of the shortlist, scoring, the report (fewer when no pair is fitted)."""
DIAGNOSE_FILES = ("diagnosis.json", "improved_model.json")
"""The files :func:`run_diagnose` writes besides the report's."""


@dataclass(frozen=True)
class DiagnoseResult:
    """The diagnosis and the files written for it."""

    diagnosis: Diagnosis
    json_path: Path  # diagnosis.json
    improved_model_path: Path  # improved_model.json, which the caliper-model node loads
    report_path: Path  # report.html, its figures beside it


def run_diagnose(
    recording_path: Path,
    rig_path: Path,
    out: Path,
    progress: Progress | None = None,
    ready: Callable[[], None] | None = None,
) -> DiagnoseResult:
    """Diagnose the recording against the rig file; write its JSON, model and report.

    Args:
        recording_path: a recording with ``p_i`` and the three measured outputs.
        rig_path: the nominal rig YAML (what the test engineer believes).
        out: folder for ``diagnosis.json``, ``improved_model.json`` and ``report.html``.
        progress: called with a message at each step (about :data:`DIAGNOSIS_STEPS`).
        ready: called once the inputs are opened and the output folder checked, before the
            work (the command checks its database there).

    The inputs are opened and checked before the output folder is made; a refusal after
    that removes the folders it made (a refused command leaves no empty folder).

    Returns:
        The diagnosis and the paths of the files written.

    Raises:
        BrakeHilError: no such recording, a bad rig file or recording (the message names
            the file).
    """
    from brake_hil.report.diagnosis_report import REPORT_FILES, write_report

    opened = open_recording(recording_path, rig_path)  # the inputs first: a refusal writes nothing
    recording, rig = opened.recording, opened.rig
    with removed_if_refused(out):
        check_outputs(folder=out, names=(*DIAGNOSE_FILES, *REPORT_FILES))
        if ready is not None:
            ready()
        with naming(recording_path):
            diagnosis = diagnose(recording, rig, progress)
    json_path = output_file(out, "diagnosis.json")
    write_json(json_path, diagnosis.as_dict())
    improved = diagnosis.improved_model(rig_path).save(output_file(out, "improved_model.json"))
    if progress is not None:
        progress("writing the report")
    page = write_report(diagnosis, out, rig_path)
    return DiagnoseResult(diagnosis, json_path, improved, page)
