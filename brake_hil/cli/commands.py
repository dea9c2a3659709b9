"""Each ``brake-hil`` sub-command: call its :mod:`brake_hil.app` function, print the result.

Every function takes the parsed arguments, shows progress on stderr where the work is long,
prints the command's text on stdout, and returns the exit status (0, or 1 for ``regress``
when a metric moved). Errors on bad input propagate as
:class:`~brake_hil.errors.BrakeHilError` for :func:`brake_hil.cli.main` to print.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys

from tqdm import tqdm

from brake_hil.app.benchmark import CaseResult, run_benchmark
from brake_hil.app.cases import run_cases
from brake_hil.app.characterize import run_characterize
from brake_hil.app.compare import run_compare
from brake_hil.app.diagnose import DIAGNOSIS_STEPS, run_diagnose
from brake_hil.app.recover import RecoverResult, run_recover
from brake_hil.app.regress import MetricCheck, run_regression
from brake_hil.app.simulate import run_simulate, run_virtual_simulate

__all__ = [
    "benchmark",
    "cases",
    "characterize",
    "compare",
    "diagnose",
    "format_checks",
    "regress",
    "simulate_lti",
    "simulate_virtual",
]


def _json_written(path: Path | None) -> None:
    if path is not None:
        print(f"json written to {path}")


def compare(args: argparse.Namespace) -> int:
    """``brake-hil compare``: the seed's Table 4-5 metrics per channel."""
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
    """``brake-hil diagnose``: the verdict, its explanation and where the files are."""
    with tqdm(
        total=DIAGNOSIS_STEPS,
        desc="diagnose",
        unit="step",
        file=sys.stderr,
        disable=not sys.stderr.isatty(),
    ) as bar:

        def progress(message: str) -> None:
            bar.set_postfix_str(message)
            bar.update(1)

        result = run_diagnose(args.recording, args.rig, args.out, progress)
        bar.n = bar.total
        bar.refresh()
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
    result = run_simulate(args.rig, args.out, args.max_pressure, args.pulsing_seconds, args.seed)
    print(f"wrote {result.out} ({result.samples} samples, {result.duration_s:.1f} s)")
    return 0


def simulate_virtual(args: argparse.Namespace) -> int:
    """``brake-hil simulate`` on the virtual rig, with a progress bar of simulated time."""
    bars: list[tqdm] = []

    def progress(simulated: float, total: float) -> None:
        if not bars:
            bars.append(
                tqdm(
                    total=round(total, 3),
                    unit="s",
                    desc="virtual rig",
                    file=sys.stderr,
                    bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} s "
                    "simulated [{elapsed}<{remaining}]",
                )
            )
        bars[0].update(max(0.0, round(simulated, 3) - bars[0].n))

    try:
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
    finally:
        for bar in bars:
            bar.close()
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
    bars: list[tqdm] = []

    def progress(done: int, total: int) -> None:
        if not bars:
            bars.append(tqdm(total=total, unit="case", desc="cases", file=sys.stderr))
        bars[0].update(done - bars[0].n)

    try:
        result = run_cases(
            args.out,
            args.count,
            args.seed,
            pulsing_s=args.pulsing_seconds,
            jobs=args.jobs,
            error_scale=args.error_scale,
            kinds=tuple(args.kind),
            progress=progress,
        )
    finally:
        for bar in bars:
            bar.close()
    print(f"wrote {result.count} cases under {result.cases_dir}; labels in {result.labels_path}")
    return 0


def benchmark(args: argparse.Namespace) -> int:
    """``brake-hil benchmark``: a line per case as its verdict comes in, then the figures."""

    def show(result: CaseResult) -> None:
        verdict = ", ".join(result.effects) or "none"
        print(
            f"case {result.case}: {verdict} ({result.confidence:.2f}, {result.seconds:.1f} s)"
            + (f" error: {result.error}" if result.error else ""),
            flush=True,
        )

    result = run_benchmark(args.directory, args.jobs, args.json, show)
    figures = result.figures
    rows = [
        ("top-1 accuracy, single effects", "top1_accuracy_single", "single_effect_cases"),
        ("exact-set accuracy, pairs", "exact_set_accuracy_pairs", "pair_cases"),
        ("false-positive rate, null cases", "false_positive_rate_null", "null_cases"),
        ("unexplained recall", "unexplained_recall", "unexplained_cases"),
    ]
    for text, key, count in rows:
        print(f"{text:40s}{100 * _number(figures[key]):6.1f} %  of {figures[count]} cases")
    print(
        f"{'held-out NRMSE improvement, median':40s}"
        f"{_number(figures['held_out_nrmse_improvement_median']):6.2f} x"
    )
    print(
        f"{'seconds per recording, mean / max':40s}"
        f"{_number(figures['seconds_per_recording_mean']):6.1f} / "
        f"{_number(figures['seconds_per_recording_max']):.1f}"
    )
    _json_written(result.json_path)
    return 0


def _number(value: object) -> float:
    """A figure of :func:`~brake_hil.app.benchmark.score` as a float."""
    assert isinstance(value, int | float)
    return float(value)


def regress(args: argparse.Namespace) -> int:
    """``brake-hil regress``: 0 when nothing moved (or the baseline was written), else 1."""
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
    for line in format_checks(result.checks):
        print(line)
    if result.updated:
        print(f"baseline written to {result.baseline_path}")
        return 0
    if result.moved:
        print(f"{len(result.moved)} metrics moved past their tolerance or have no baseline")
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
