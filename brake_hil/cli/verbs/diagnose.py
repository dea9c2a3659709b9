"""``brake-hil diagnose``: one recording, or many on Dask."""

from __future__ import annotations

import argparse
from contextlib import ExitStack
from pathlib import Path
import sys
from typing import TYPE_CHECKING

from tqdm import tqdm

from brake_hil.app.recordings import recording_name, rig_beside
from brake_hil.cli.progress import FleetBar, fleet_bar, progress_bar
from brake_hil.cli.verb import RECORDING_HELP, Verb, add_database_argument, json_written
from brake_hil.cli.workers import add_workers_arguments, workers_from_args

if TYPE_CHECKING:
    from brake_hil.app.diagnose_many import RecordingDiagnosis
    from brake_hil.app.parallel import Outcome

__all__ = ["DiagnoseVerb", "diagnose_many", "diagnose_one"]


class DiagnoseVerb(Verb):
    """One recording (:func:`diagnose_one`) or many (:func:`diagnose_many`).

    Several paths, a glob or a folder of recordings are many
    (:func:`~brake_hil.app.recordings.names_many`).
    """

    name = "diagnose"
    help = "find and model the physics the model left out"
    description = (
        "Diagnose one recording, or many: folders of recordings and globs "
        "(quoted, e.g. 'lab/**/run-*') are diagnosed on Dask, each into its own folder under "
        "--out, and every result is appended to the results database."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``RECORDING... [--rig] [--out] [--db]`` and the workers' options."""
        parser.add_argument(
            "recording",
            type=Path,
            nargs="+",
            help=RECORDING_HELP + "; or folders of recordings, or globs (many recordings)",
        )
        parser.add_argument(
            "--rig",
            type=Path,
            help="the nominal rig file (YAML; default: RECORDING.rig.yaml beside each recording)",
        )
        parser.add_argument(
            "--out",
            type=Path,
            help="folder for diagnosis.json, improved_model.json and report.html (default: "
            "out/<recording name>/ in the working directory); many recordings: the folder that "
            "gets one folder per recording (default: out/)",
        )
        add_database_argument(parser, "default: results.sqlite in the output folder")
        add_workers_arguments(parser)

    def main(self, args: argparse.Namespace) -> int:
        """:func:`diagnose_one` or :func:`diagnose_many`."""
        from brake_hil.app.recordings import names_many

        if names_many(args.recording):
            return diagnose_many(args)
        args.recording = args.recording[0]
        return diagnose_one(args)


def diagnose_one(args: argparse.Namespace) -> int:
    """One recording: the verdict, its explanation, where the files are; results to the DB.

    ``--rig`` defaults to ``RECORDING.rig.yaml`` beside the recording, ``--out`` to
    ``out/<recording name>/``; the command says which it used. The results go to ``--db``, or
    ``results.sqlite`` in ``--out`` (default: in ``out/``).
    """
    from brake_hil.app.diagnose import DIAGNOSIS_STEPS, run_diagnose
    from brake_hil.app.output import removed_if_refused
    from brake_hil.app.results_db import (
        DATABASE_NAME,
        append_diagnosis,
        check_database,
        database_folder,
    )
    from brake_hil.io.recording_paths import existing_recording

    existing_recording(args.recording)  # a typo named as such, before its rig file is sought
    rig = args.rig if args.rig is not None else rig_beside(args.recording)
    out = args.out if args.out is not None else Path("out") / recording_name(args.recording)
    database = args.db or (args.out or Path("out")) / DATABASE_NAME
    if args.rig is None:
        print(f"rig file: {rig} (beside the recording; --rig to choose another)")
    if args.out is None:
        print(f"output folder: {out} (--out to choose another)")
    sys.stdout.flush()
    with ExitStack() as stack:
        # the output folder and the database once the inputs are opened: a refusal writes
        # nothing (the folder checked before the database in it: its own problem named)
        stack.enter_context(removed_if_refused(out, database_folder(database)))
        bars: list[tqdm] = []  # type: ignore[type-arg]  # made at the first step: bad input
        # before it leaves the one error line alone on stderr

        def progress(message: str) -> None:
            if not bars:
                bars.append(stack.enter_context(progress_bar(DIAGNOSIS_STEPS, "diagnose", "step")))
            bar = bars[0]
            if message.startswith("left out"):
                bar.write(f"diagnose: {message}", file=sys.stderr)
                return
            if bar.n + 1 > bar.total:  # never "17 steps of 16"
                bar.total = bar.n + 1
            bar.set_postfix_str(message, refresh=False)
            bar.update(1)

        result = run_diagnose(args.recording, rig, out, progress, lambda: check_database(database))
        if bars:
            bars[0].n = bars[0].total
            bars[0].set_postfix_str("done")
    diagnosis = result.diagnosis
    json_written(result.json_path)
    print(f"improved model written to {result.improved_model_path} (caliper_model loads it)")
    verdict = ", ".join(diagnosis.effects) or "none (the calibrated LTI model suffices)"
    print(f"verdict: {verdict} (confidence {diagnosis.confidence_text()})")
    from brake_hil.diagnosis.rig_findings import verdict_notes

    for line in verdict_notes({"rig_values": diagnosis.rig_values, "air": diagnosis.air}):
        print(line)
    print(diagnosis.explanation)
    print(f"report: {result.report_path}")
    stored = append_diagnosis(args.recording, rig, result.json_path, database)
    print(f"results appended to {stored}")
    return 0


def diagnose_many(args: argparse.Namespace) -> int:
    """Many recordings on Dask: a bar over them, a line per verdict, failures named.

    Exit status 0 when every recording was diagnosed, 2 when any failed (each named with its
    reason on stderr; the others finished and are in the database).
    """
    from brake_hil.app.diagnose_many import run_diagnose_many
    from brake_hil.diagnosis.rig_findings import verdict_notes
    from brake_hil.diagnosis.verdict import confidence_text

    out = args.out if args.out is not None else Path("out")
    with ExitStack() as stack:
        bars: list[FleetBar] = []

        def start(count: int) -> None:
            bars.append(stack.enter_context(fleet_bar(count, "diagnose", "recording")))

        def show(outcome: Outcome[RecordingDiagnosis]) -> None:
            bar = bars[0]
            if outcome.value is not None:
                done = outcome.value
                verdict = ", ".join(done.effects) or "none"
                seconds = f"{done.seconds:.1f} s"
                cap = done.document["verdict"].get("confidence_cap")
                sure = confidence_text(done.confidence, cap if isinstance(cap, str) else None)
                notes = "".join(f"; {n}" for n in verdict_notes(done.document["verdict"]))
                bar.write(f"{done.job.recording}: {verdict} ({sure}, {seconds}){notes}")
            bar.finished(outcome.ok)

        result = run_diagnose_many(
            args.recording, args.rig, out, workers_from_args(args), args.db, show, start
        )
    failed = result.failed
    print(
        f"diagnosed {len(result.jobs) - len(failed)} of {len(result.jobs)} recordings in "
        f"{result.seconds:.0f} s; one folder each under {out}; results in {result.database}"
    )
    for job, reason in failed:
        print(f"brake-hil diagnose: {job.recording}: {reason}", file=sys.stderr)
    return 2 if failed else 0
