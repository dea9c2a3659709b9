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

from brake_hil.cli.progress import progress_bar

if TYPE_CHECKING:
    from brake_hil.app.benchmark import CaseResult
    from brake_hil.app.recover import RecoverResult
    from brake_hil.app.regress import MetricCheck

__all__ = [
    "benchmark",
    "cases",
    "characterize",
    "compare",
    "diagnose",
    "format_checks",
    "recording_name",
    "regress",
    "rig_beside",
    "simulate_lti",
    "simulate_virtual",
]


def _json_written(path: Path | None) -> None:
    if path is not None:
        print(f"json written to {path}")


def compare(args: argparse.Namespace) -> int:
    """``brake-hil compare``: the seed's Table 4-5 metrics per channel."""
    from brake_hil.app.compare import run_compare

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
    """``brake-hil diagnose``: the verdict, its explanation and where the files are.

    ``--rig`` defaults to ``RECORDING.rig.yaml`` beside the recording, ``--out`` to
    ``out/<recording name>/``; the command says which it used.
    """
    from brake_hil.app.diagnose import DIAGNOSIS_STEPS, run_diagnose

    rig = args.rig if args.rig is not None else rig_beside(args.recording)
    out = args.out if args.out is not None else Path("out") / recording_name(args.recording)
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
    return 0


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
    """``brake-hil cases``, with a progress bar of cases written."""
    from brake_hil.app.cases import run_cases

    with ExitStack() as stack:
        bars: list[tqdm] = []  # type: ignore[type-arg]

        def progress(done: int, total: int) -> None:
            if not bars:
                bars.append(stack.enter_context(progress_bar(total, "cases", "case")))
            bars[0].update(done - bars[0].n)

        result = run_cases(
            args.out,
            args.count,
            args.seed,
            pulsing_s=args.pulsing_seconds,
            jobs=args.jobs,
            error_scale=args.error_scale,
            kinds=tuple(args.kind),
            family=args.family,
            progress=progress,
        )
    print(f"wrote {result.count} cases under {result.cases_dir}; labels in {result.labels_path}")
    return 0


def benchmark(args: argparse.Namespace) -> int:
    """``brake-hil benchmark``: a bar of cases, a line per case as its verdict comes in.

    Then the figures; a figure over no case is ``n/a``.
    """
    from brake_hil.app.benchmark import case_count, run_benchmark

    with ExitStack() as stack:
        bars: list[tqdm] = []  # type: ignore[type-arg]

        def start() -> None:  # once the cases are known to exist: bad input stays one line
            bars.append(stack.enter_context(progress_bar(count, "benchmark", "case")))

        def show(result: CaseResult) -> None:
            if not bars:
                start()
            bar = bars[0]
            verdict = ", ".join(result.effects) or "none"
            bar.write(
                f"case {result.case}: {verdict} ({result.confidence:.2f}, {result.seconds:.1f} s)"
                + (f" error: {result.error}" if result.error else ""),
                file=sys.stdout,
            )
            sys.stdout.flush()
            bar.update(1)

        count = case_count(args.directory)
        if count and (args.directory / "labels.json").is_file():
            start()
        result = run_benchmark(args.directory, args.jobs, args.json, show)
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
    return 0


def _figure(value: object, scale: float, spec: str, suffix: str = "") -> str:
    """A figure of :func:`~brake_hil.app.benchmark.score`; ``n/a`` when over no case (NaN)."""
    if not isinstance(value, int | float) or math.isnan(value):
        width = spec.split(".")[0]
        return f"{'n/a':>{width or 0}s}" + (" " * len(suffix) if suffix else "")
    return f"{scale * value:{spec}}{suffix}"


def rig_beside(recording: Path) -> Path:
    """``RECORDING.rig.yaml`` beside a recording (a bag folder or a bare ``.mcap``/``.db3``).

    Raises:
        BrakeHilError: no such file (the message says to pass ``--rig``).
    """
    from brake_hil.errors import BrakeHilError

    base = Path(str(recording).rstrip("/"))
    candidates = [base.parent / f"{base.name}.rig.yaml"]
    if base.suffix in (".mcap", ".db3"):
        candidates.append(base.with_suffix(".rig.yaml"))
    for path in candidates:
        if path.is_file():
            return path
    raise BrakeHilError(f"{recording}: no rig file beside it ({candidates[0]}); pass --rig")


def recording_name(recording: Path) -> str:
    """A recording's name: its folder's, or its file's without the suffix."""
    base = Path(str(recording).rstrip("/"))
    return base.stem if base.suffix in (".mcap", ".db3") else base.name


def regress(args: argparse.Namespace) -> int:
    """``brake-hil regress``: 0 when nothing moved (or the baseline was written), else 1."""
    from brake_hil.app.regress import run_regression

    result = run_regression(args.recordings, args.baseline, args.model, args.update, args.jobs)
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
