"""Each ``brake-hil`` sub-command: call its :mod:`brake_hil.app` function, print the result.

Every function takes the parsed arguments, shows progress on stderr where the work is long,
prints the command's text on stdout, and returns the exit status (0, or 1 for ``regress``
when a metric moved). Errors on bad input propagate as
:class:`~brake_hil.errors.BrakeHilError` for :func:`brake_hil.cli.main` to print.
"""

from __future__ import annotations

import argparse
from contextlib import ExitStack
import math
from pathlib import Path
import sys
from typing import TYPE_CHECKING

from tqdm import tqdm

from brake_hil.app.recordings import recording_name, rig_beside
from brake_hil.cli.progress import FleetBar, fleet_bar, progress_bar

if TYPE_CHECKING:
    from brake_hil.app.benchmark import CaseResult
    from brake_hil.app.diagnose_many import RecordingDiagnosis
    from brake_hil.app.parallel import Outcome
    from brake_hil.app.recover import RecoverResult
    from brake_hil.app.regress import MetricCheck, ReplayResult
    from brake_hil.virtual_rig.cases import CaseDrive

__all__ = [
    "benchmark",
    "cases",
    "characterize",
    "compare",
    "diagnose",
    "diagnose_many",
    "diagnose_one",
    "fleet",
    "format_checks",
    "recording_name",
    "regress",
    "rig_beside",
    "simulate_lti",
    "simulate_virtual",
    "trend",
]


def _json_written(path: Path | None) -> None:
    if path is not None:
        print(f"json written to {path}")


def compare(args: argparse.Namespace) -> int:
    """``brake-hil compare``: the seed's Table 4-5 metrics per channel."""
    from brake_hil.app.compare import run_compare
    from brake_hil.app.results_db import check_database

    check_database(args.db)
    result = run_compare(args.recording, args.rig, args.json, args.plot)
    print(f"recording {args.recording}  rig {args.rig} ({result.rig.name})")
    for segment in result.comparison.segments:
        print(
            f"segment {segment.t_start:6.2f}-{segment.t_end:6.2f} s, "
            f"mean p_i {segment.mean_pressure / 1e6:.2f} MPa"
        )
    print(f"{'channel':8s}{'ptp ratio %':>13s}{'tau/T %':>10s}{'NRMSE':>9s}{'cycles':>8s}")
    for channel, m in result.comparison.metrics().items():
        print(
            f"{channel:8s}{m['ptp_ratio_pct']:13.1f}{m['tau_over_T_pct']:10.2f}"
            f"{m['nrmse']:9.4f}{int(m['cycles']):8d}"
        )
    if result.plot_path is not None:
        print(f"plot written to {result.plot_path}")
    _json_written(result.json_path)
    if args.db:
        from brake_hil.app.results_db import append_comparison

        stored = append_comparison(args.recording, args.rig, result.comparison.metrics(), args.db)
        print(f"results appended to {stored}")
    return 0


def characterize(args: argparse.Namespace) -> int:
    """``brake-hil characterize``: the seed's Table 3 per steady segment."""
    from brake_hil.app.characterize import run_characterize

    result = run_characterize(args.recording, args.rig, args.json)
    header = (
        f"{'segment s':>13s}{'max p MPa':>10s}{'k_eh*':>7s}{'eta_eh':>7s}"
        f"{'2c_fs*':>7s}{'2c_ss*':>7s}{'2c_fb*':>7s}{'xi':>6s}  slips"
    )
    print(f"recording {args.recording}  rig {args.rig} ({result.rig.name})")
    print(header)
    for s in result.segments:
        print(
            f"{s.t_start:6.2f}-{s.t_end:6.2f}{s.max_pressure / 1e6:10.2f}{s.k_eh_star:7.3f}"
            f"{s.eta_eh:7.3f}{s.two_c_fs_star:7.3f}{s.two_c_ss_star:7.3f}{s.two_c_fb_star:7.3f}"
            f"{s.xi:6.2f}  {'yes' if s.seal_slips else 'no'}"
        )
    _json_written(result.json_path)
    return 0


def diagnose(args: argparse.Namespace) -> int:
    """``brake-hil diagnose``: one recording (:func:`diagnose_one`) or many.

    Several paths, a glob or a folder of recordings are many
    (:func:`~brake_hil.app.recordings.names_many`).
    """
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
    from brake_hil.app.results_db import DATABASE_NAME, append_diagnosis, check_database
    from brake_hil.files import check_output_folder

    rig = args.rig if args.rig is not None else rig_beside(args.recording)
    out = args.out if args.out is not None else Path("out") / recording_name(args.recording)
    database = args.db or (args.out or Path("out")) / DATABASE_NAME
    check_output_folder(out)  # before the database in it: the folder's own problem named
    check_database(database)
    if args.rig is None:
        print(f"rig file: {rig} (beside the recording; --rig to choose another)")
    if args.out is None:
        print(f"output folder: {out} (--out to choose another)")
    sys.stdout.flush()
    with ExitStack() as stack:
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

        result = run_diagnose(args.recording, rig, out, progress)
        if bars:
            bars[0].n = bars[0].total
            bars[0].set_postfix_str("done")
    diagnosis = result.diagnosis
    _json_written(result.json_path)
    print(f"improved model written to {result.improved_model_path} (caliper_model loads it)")
    verdict = ", ".join(diagnosis.effects) or "none (the calibrated LTI model suffices)"
    print(f"verdict: {verdict} (confidence {diagnosis.confidence:.2f})")
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
    from brake_hil.cli.progress import fleet_bar
    from brake_hil.cli.workers import workers_from_args

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
                bar.write(f"{done.job.recording}: {verdict} ({done.confidence:.2f}, {seconds})")
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


def simulate_lti(args: argparse.Namespace) -> int:
    """``brake-hil simulate`` of the LTI model."""
    from brake_hil.app.simulate import run_simulate

    result = run_simulate(args.rig, args.out, args.max_pressure, args.pulsing_seconds, args.seed)
    print(f"wrote {result.out} ({result.samples} samples, {result.duration_s:.1f} s)")
    return 0


def simulate_virtual(args: argparse.Namespace) -> int:
    """``brake-hil simulate`` on the virtual rig, with a progress bar of simulated time."""
    from brake_hil.app.simulate import run_virtual_simulate

    with ExitStack() as stack:
        bars: list[tqdm] = []  # type: ignore[type-arg]

        def progress(simulated: float, total: float) -> None:
            if not bars:
                bars.append(
                    stack.enter_context(
                        progress_bar(
                            round(total, 3),
                            "virtual rig",
                            "s",
                            bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} "
                            "s simulated [{elapsed}<{remaining}]",
                        )
                    )
                )
            bars[0].update(max(0.0, round(simulated, 3) - bars[0].n))

        result = run_virtual_simulate(
            args.rig,
            args.out,
            max_pressures=args.max_pressure,
            pulsing_s=args.pulsing_seconds,
            seed=args.seed,
            effects=args.effect or (),
            excitation=args.excitation,
            nominal_path=args.nominal,
            rig_out=args.rig_out,
            method=args.method,
            rtol=args.rtol,
            progress=progress,
        )
    run = result.run
    names = ", ".join(f"{e.name}={e.strength:g}" for e in run.effects) or "no effect"
    print(f"wrote {result.out} ({run.time.size} samples, {run.time[-1]:.1f} s; {names})")
    print(f"  excitation: {result.excitation.label}")
    print(f"  rig file (nominal): {result.rig_path}")
    seconds = run.solver.seconds
    duration = result.excitation.duration
    print(f"  solver: {run.solver.method}, {seconds:.1f} s for {duration:.1f} s")
    return 0


def cases(args: argparse.Namespace) -> int:
    """``brake-hil cases``, with a progress bar of cases written, failed and left."""
    from brake_hil.app.cases import run_cases
    from brake_hil.cli.workers import workers_from_args

    workers = workers_from_args(args)
    with ExitStack() as stack:
        bars: list[FleetBar] = []

        def progress(done: int, failed: int, total: int) -> None:
            if not bars:
                bars.append(stack.enter_context(fleet_bar(total, "cases", "case")))
            bars[0].count(done, failed)

        result = run_cases(
            args.out,
            args.count,
            args.seed,
            pulsing_s=args.pulsing_seconds,
            workers=workers,
            error_scale=args.error_scale,
            kinds=tuple(args.kind),
            family=args.family,
            drive=case_drive(args),
            progress=progress,
        )
    print(f"wrote {result.count} cases under {result.cases_dir}; labels in {result.labels_path}")
    return 0


def case_drive(args: argparse.Namespace) -> CaseDrive:
    """The cases' drive from ``--excitation-hz`` and ``--max-pressures`` (the seed's)."""
    from brake_hil.virtual_rig.cases import CaseDrive

    if args.max_pressures is None:
        return CaseDrive(args.excitation_hz)
    return CaseDrive(args.excitation_hz, args.max_pressures)


def fleet(args: argparse.Namespace) -> int:
    """``brake-hil fleet``, with a progress bar of recordings written."""
    from brake_hil.app.fleet import run_fleet
    from brake_hil.cli.workers import workers_from_args

    with ExitStack() as stack:
        bars: list[tqdm] = []  # type: ignore[type-arg]

        def progress(done: int, total: int) -> None:
            if not bars:
                bars.append(stack.enter_context(progress_bar(total, "fleet", "recording")))
            bars[0].update(done - bars[0].n)

        result = run_fleet(
            args.out,
            args.runs,
            args.seed,
            pulsing_s=args.pulsing_seconds,
            workers=workers_from_args(args),
            progress=progress,
        )
    print(
        f"wrote {result.recordings} recordings of {', '.join(result.rigs)} under {result.out} "
        f"(what was simulated: {result.truth_path})"
    )
    print(
        f"next: brake-hil diagnose {result.out} --out OUT, then "
        "brake-hil trend --db OUT/results.sqlite"
    )
    return 0


def benchmark(args: argparse.Namespace) -> int:
    """``brake-hil benchmark``: a bar of cases, a line per case as its verdict comes in.

    Then the figures; a figure over no case is ``n/a``.
    """
    from brake_hil.app.benchmark import INTERNAL_ERROR, case_count, run_benchmark
    from brake_hil.cli.workers import workers_from_args

    workers = workers_from_args(args)
    with ExitStack() as stack:
        bars: list[FleetBar] = []

        def start() -> None:  # once the cases are known to exist: bad input stays one line
            bars.append(stack.enter_context(fleet_bar(count, "benchmark", "case")))

        def show(result: CaseResult) -> None:
            if not bars:
                start()
            verdict = ", ".join(result.effects) or "none"
            bars[0].write(
                f"case {result.case}: {verdict} ({result.confidence:.2f}, {result.seconds:.1f} s)"
                + (f" error: {result.error}" if result.error else "")
            )
            bars[0].finished(not result.error)

        count = case_count(args.directory)
        if count and (args.directory / "labels.json").is_file():
            start()
        result = run_benchmark(args.directory, workers, args.json, show)
    figures = result.figures
    rows = [
        ("top-1 accuracy, single effects", "top1_accuracy_single", "single_effect_cases"),
        ("exact-set accuracy, pairs", "exact_set_accuracy_pairs", "pair_cases"),
        ("false-positive rate, null cases", "false_positive_rate_null", "null_cases"),
        ("unexplained recall", "unexplained_recall", "unexplained_cases"),
    ]
    for text, key, cases_key in rows:
        share = _figure(figures[key], 100.0, "6.1f", " %")
        print(f"{text:40s}{share}  of {figures[cases_key]} cases")
    improvement = _figure(figures["held_out_nrmse_improvement_median"], 1.0, "6.2f", " x")
    print(f"{'held-out NRMSE improvement, median':40s}{improvement}")
    mean = _figure(figures["seconds_per_recording_mean"], 1.0, "6.1f")
    most = _figure(figures["seconds_per_recording_max"], 1.0, ".1f")
    print(f"{'seconds per recording, mean / max':40s}{mean} / {most}")
    wrong = _figure(figures["wrong_share_of_sure_verdicts"], 100.0, "6.1f", " %")
    print(f"{'wrong among verdicts at >= 0.9':40s}{wrong}  of {figures['sure_verdicts']} verdicts")
    print("confidence     cases  mean  right")
    for row in figures["reliability"]:  # type: ignore[attr-defined]
        low, high = row["confidence"]
        print(
            f"{low:4.2f}-{high:4.2f}  {row['cases']:7d}  {row['mean_confidence']:4.2f}  "
            f"{100 * row['accuracy']:5.1f} %"
        )
    _json_written(result.json_path)
    failed = [r.case for r in result.results if r.error.startswith(INTERNAL_ERROR)]
    if failed:
        print(
            f"brake-hil benchmark: {args.directory}: the diagnosis failed on {len(failed)} "
            f"case(s) (an internal error, scored as none; the errors are in the JSON): "
            + ", ".join(failed),
            file=sys.stderr,
        )
        return 1
    return 0


def _figure(value: object, scale: float, spec: str, suffix: str = "") -> str:
    """A figure of :func:`~brake_hil.app.benchmark.score`; ``n/a`` when over no case (NaN)."""
    if not isinstance(value, int | float) or math.isnan(value):
        width = spec.split(".")[0]
        return f"{'n/a':>{width or 0}s}" + (" " * len(suffix) if suffix else "")
    return f"{scale * value:{spec}}{suffix}"


def regress(args: argparse.Namespace) -> int:
    """``brake-hil regress``: 0 when nothing moved (or the baseline was written), else 1.

    A bar of recordings replayed (one without steady pulsing counts as done: it is skipped
    with a note, not failed), from before the baseline and model are read: their refusal
    comes sooner than the bar's first draw.
    """
    from brake_hil.app.regress import run_regression
    from brake_hil.app.results_db import check_database
    from brake_hil.cli.workers import workers_from_args
    from brake_hil.errors import NoSteadyPulsingError

    workers = workers_from_args(args)
    check_database(args.db)
    with fleet_bar(len(args.recordings), "regress") as bar:

        def progress(outcome: Outcome[ReplayResult]) -> None:
            bar.finished(outcome.ok or isinstance(outcome.error, NoSteadyPulsingError))

        result = run_regression(
            args.recordings, args.baseline, args.model, args.update, workers, progress
        )
    for key, replay in result.results.items():
        print(
            f"{key}: {replay.samples} samples ({replay.duration_s:.1f} s) replayed through "
            f"{result.model_file} at {replay.replay_factor:.0f}x real time, "
            f"{len(replay.segments)} steady segments scored"
        )
    print(
        f"{len(result.results)} recordings, {result.data_s:.1f} s of data in "
        f"{result.wall_s:.2f} s wall time"
    )
    for key, reason in result.skipped.items():
        lost = " (in the baseline: FAILED)" if key in result.lost else ""
        print(f"{key}: skipped, no steady 5 Hz pulsing to score{lost} -- {reason}")
    if result.checks:
        for line in format_checks(result.checks):
            print(line)
    if args.db and result.results:
        from brake_hil.app.results_db import append_regression

        replays = {Path(r.recording): r.metrics for r in result.results.values()}
        print(f"results appended to {append_regression(replays, result.model_file, args.db)}")
    if result.updated:
        print(f"baseline written to {result.baseline_path}")
        return 0
    if result.moved:
        print(f"{len(result.moved)} metrics moved past their tolerance or have no baseline")
    if result.lost:
        print(f"{len(result.lost)} recordings of the baseline no longer hold steady pulsing")
    if result.failed:
        return 1
    if not result.results:
        print("no recording scored")
        return 1
    print("every metric within its tolerance")
    return 0


def format_checks(checks: tuple[MetricCheck, ...]) -> list[str]:
    """The table ``regress`` prints: one line per bag, channel and metric."""
    width = max([len(c.bag) for c in checks] + [3])
    lines = [
        f"{'bag':{width}s}  {'channel':7s} {'metric':15s}{'baseline':>12s}{'now':>12s}"
        f"{'delta':>11s}{'tol':>9s}  status"
    ]
    for c in checks:
        baseline = "-" if c.baseline is None else f"{c.baseline:.5g}"
        delta = "-" if c.baseline is None else f"{c.delta:+.3g}"
        lines.append(
            f"{c.bag:{width}s}  {c.channel:7s} {c.metric:15s}{baseline:>12s}{c.value:12.5g}"
            f"{delta:>11s}{c.tolerance:9.3g}  {c.status}"
        )
    return lines


def recover(args: argparse.Namespace) -> int:
    """``brake-hil recover``: 0 when a finished copy was written."""
    from brake_hil.app.recover import run_recover

    result = run_recover(args.bag, args.out)
    for line in format_recovery(result):
        print(line)
    return 0


def trend(args: argparse.Namespace) -> int:
    """``brake-hil trend``: per rig, one line per finding, then where the page is."""
    from brake_hil.app.trend import run_trend

    result = run_trend(args.db, args.rig, args.out)
    for rig in result.rigs:
        print(f"{rig.rig}: {len(rig.rows)} diagnoses")
        for line in rig.summary():
            print(f"  {line}")
    print(f"report: {result.report_path}")
    return 0


def format_recovery(result: RecoverResult) -> list[str]:
    """What ``recover`` prints: the verdict, one line per file, one per topic."""
    state = f"unfinished ({result.reason})" if result.reason else "finished already"
    lines = [
        f"{result.source}: {state}; {result.message_count} messages in "
        f"{len(result.files)} files written to {result.output} (summaries, indexes, "
        "statistics, metadata.yaml)"
    ]
    for item in result.files:
        if item.finished:
            how = "finished"
        else:
            how = f"{item.stop}; {item.lost_bytes} bytes after the last whole record dropped"
        skipped = f", {item.skipped} without channel or schema left out" if item.skipped else ""
        names = f"{item.source.name} -> {item.output.name}"
        lines.append(f"  {names}: {item.messages} messages{skipped} ({how})")
    lines += [f"  {name} ({msgtype}): {count} messages" for name, msgtype, count in result.topics]
    return lines
