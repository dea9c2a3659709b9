"""``brake-hil``: the command line of interface.md.

``main()`` only parses; each sub-command is a function that does the work. Bad input (a
missing file, a corrupt bag, a missing topic, NaN samples, stamps going backwards, a bad rig
key) ends with one line on stderr naming the file and the problem, and exit status 2.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
import json
from pathlib import Path
import sys
from typing import Any

import numpy as np

from brake_hil.analysis.characterization import characterize
from brake_hil.analysis.comparison import compare, predict
from brake_hil.app.regress import run_regression
from brake_hil.errors import BrakeHilError
from brake_hil.io.recording_reader import read_recording
from brake_hil.io.recording_writer import write_recording
from brake_hil.physics.excitation import pulsing_profile
from brake_hil.physics.measurement import SENSORS, measure
from brake_hil.physics.parameters import derive_parameters
from brake_hil.physics.rig import load_rig
from brake_hil.topics import (
    BLOCK_FORCE,
    BORE_PRESSURE,
    CALIPER_DISPLACEMENT,
    MASTER_CYLINDER_PRESSURE,
    MEASURED_OUTPUTS,
)
from brake_hil.virtual_rig import cli as virtual_rig_cli

EXIT_BAD_INPUT = 2


def run_compare(
    recording_path: Path, rig_path: Path, json_path: Path | None, plot_path: Path | None
) -> dict[str, object]:
    """``brake-hil compare``: the rig file's model against the recording (Tables 4-5)."""
    rig = load_rig(rig_path)
    recording = read_recording(
        recording_path, required=(MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS)
    )
    comparison = compare(recording, rig)
    result = {"recording": str(recording_path), "rig": str(rig_path), **comparison.as_dict()}
    print(f"recording {recording_path}  rig {rig_path} ({rig.name})")
    for segment in comparison.segments:
        print(
            f"segment {segment.t_start:6.2f}-{segment.t_end:6.2f} s, "
            f"mean p_i {segment.mean_pressure / 1e6:.2f} MPa"
        )
    print(f"{'channel':8s}{'ptp ratio %':>13s}{'tau/T %':>10s}{'NRMSE':>9s}{'cycles':>8s}")
    for channel, m in comparison.metrics().items():
        print(
            f"{channel:8s}{m['ptp_ratio_pct']:13.1f}{m['tau_over_T_pct']:10.2f}"
            f"{m['nrmse']:9.4f}{int(m['cycles']):8d}"
        )
    if plot_path is not None:
        from brake_hil.report.plots import plot_comparison

        plot_comparison(comparison, plot_path, f"{recording_path.name}: {rig.name}")
        print(f"plot written to {plot_path}")
    _write_json(json_path, result)
    return result


def run_characterize(
    recording_path: Path, rig_path: Path, json_path: Path | None
) -> dict[str, object]:
    """``brake-hil characterize``: the seed's Table 3 (and Table 1) per steady segment."""
    rig = load_rig(rig_path)
    recording = read_recording(
        recording_path, required=(MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS)
    )
    segments = characterize(recording, rig)
    result: dict[str, object] = {
        "recording": str(recording_path),
        "segments": [s.as_dict() for s in segments],
    }
    header = (
        f"{'segment s':>13s}{'max p MPa':>10s}{'k_eh*':>7s}{'eta_eh':>7s}"
        f"{'2c_fs*':>7s}{'2c_ss*':>7s}{'2c_fb*':>7s}{'xi':>6s}  slips"
    )
    print(f"recording {recording_path}  rig {rig_path} ({rig.name})")
    print(header)
    for s in segments:
        print(
            f"{s.t_start:6.2f}-{s.t_end:6.2f}{s.max_pressure / 1e6:10.2f}{s.k_eh_star:7.3f}"
            f"{s.eta_eh:7.3f}{s.two_c_fs_star:7.3f}{s.two_c_ss_star:7.3f}{s.two_c_fb_star:7.3f}"
            f"{s.xi:6.2f}  {'yes' if s.seal_slips else 'no'}"
        )
    _write_json(json_path, result)
    return result


def run_simulate(
    rig_path: Path, out: Path, max_pressures: Sequence[float], pulsing_s: float, seed: int
) -> Path:
    """``brake-hil simulate``: an LTI-model recording with the DAQ's noise and quantisation."""
    rig = load_rig(rig_path)
    if out.exists():
        raise BrakeHilError(f"{out}: already exists; choose a new output directory")
    time, pressure = pulsing_profile(
        max_pressures, pulsing_s=pulsing_s, pulsing_hz=rig.excitation_hz
    )
    params = derive_parameters(rig, float(np.mean(pressure[time > 1.0])))
    outputs = predict(pressure, params)
    rng = np.random.default_rng(seed)
    channels = {
        MASTER_CYLINDER_PRESSURE: measure(pressure, SENSORS["p_i"], rng),
        BORE_PRESSURE: measure(outputs["p_b"], SENSORS["p_b"], rng),
        BLOCK_FORCE: measure(outputs["F_k"], SENSORS["F_k"], rng),
        CALIPER_DISPLACEMENT: measure(outputs["x_c"], SENSORS["x_c"], rng),
    }
    write_recording(out, time, channels)
    print(f"wrote {out} ({time.size} samples, {time[-1]:.1f} s)")
    return out


def run_diagnose(recording_path: Path, rig_path: Path, out: Path) -> dict[str, object]:
    """``brake-hil diagnose``: find, name and model the physics the LTI model left out."""
    from tqdm import tqdm

    from brake_hil.diagnosis.diagnose import diagnose
    from brake_hil.report.diagnosis_report import write_report

    rig = load_rig(rig_path)
    recording = read_recording(
        recording_path, required=(MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS)
    )
    with tqdm(
        total=16, desc="diagnose", unit="step", file=sys.stderr, disable=not sys.stderr.isatty()
    ) as bar:

        def progress(message: str) -> None:
            bar.set_postfix_str(message)
            bar.update(1)

        diagnosis = diagnose(recording, rig, progress)
        bar.n = bar.total
        bar.refresh()
    result = diagnosis.as_dict()
    out.mkdir(parents=True, exist_ok=True)
    _write_json(out / "diagnosis.json", result)
    improved = diagnosis.improved_model(rig_path).save(out / "improved_model.json")
    print(f"improved model written to {improved} (caliper_model loads it)")
    page = write_report(diagnosis, out)
    verdict = ", ".join(diagnosis.effects) or "none (the calibrated LTI model suffices)"
    print(f"verdict: {verdict} (confidence {diagnosis.confidence:.2f})")
    print(diagnosis.explanation)
    print(f"report: {page}")
    return result


def run_benchmark(directory: Path, jobs: int, json_path: Path | None) -> dict[str, object]:
    """``brake-hil benchmark``: the diagnosis blind on ``DIR/cases``, scored on ``DIR/labels.json``
    only after every verdict is in."""
    from brake_hil.scoring import CaseResult, read_labels, run_cases, score

    cases = sorted(p for p in (directory / "cases").glob("*") if p.is_dir())
    if not cases:
        raise BrakeHilError(f"{directory}: no cases under {directory / 'cases'}")
    labels_path = directory / "labels.json"
    if not labels_path.exists():
        raise BrakeHilError(f"{labels_path}: no labels to score against")

    def show(result: CaseResult) -> None:
        verdict = ", ".join(result.effects) or "none"
        print(
            f"case {result.case}: {verdict} ({result.confidence:.2f}, {result.seconds:.1f} s)"
            + (f" error: {result.error}" if result.error else ""),
            flush=True,
        )

    results = run_cases(cases, workers=jobs, progress=show)
    figures: dict[str, Any] = dict(score(results, read_labels(labels_path)))
    rows = [
        ("top-1 accuracy, single effects", "top1_accuracy_single", "single_effect_cases"),
        ("exact-set accuracy, pairs", "exact_set_accuracy_pairs", "pair_cases"),
        ("false-positive rate, null cases", "false_positive_rate_null", "null_cases"),
        ("unexplained recall", "unexplained_recall", "unexplained_cases"),
    ]
    for text, key, count in rows:
        print(f"{text:40s}{100 * float(figures[key]):6.1f} %  of {figures[count]} cases")
    print(
        f"{'held-out NRMSE improvement, median':40s}"
        f"{float(figures['held_out_nrmse_improvement_median']):6.2f} x"
    )
    print(
        f"{'seconds per recording, mean / max':40s}"
        f"{float(figures['seconds_per_recording_mean']):6.1f} / "
        f"{float(figures['seconds_per_recording_max']):.1f}"
    )
    _write_json(json_path, figures)
    return figures


def _write_json(path: Path | None, result: dict[str, object]) -> None:
    if path is None:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    print(f"json written to {path}")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``brake-hil``."""
    parser = argparse.ArgumentParser(
        prog="brake-hil", description="Hardware-in-the-loop tools for hydraulic disk brakes."
    )
    commands = parser.add_subparsers(dest="command", required=True)
    cmp = commands.add_parser("compare", help="run the rig's LTI model on a recording")
    cmp.add_argument("recording", type=Path)
    cmp.add_argument("--rig", type=Path, required=True)
    cmp.add_argument("--json", type=Path)
    cmp.add_argument("--plot", type=Path, help="PNG of measured vs predicted")
    chz = commands.add_parser("characterize", help="the seed's Table 3 from a recording")
    chz.add_argument("recording", type=Path)
    chz.add_argument("--rig", type=Path, required=True)
    chz.add_argument("--json", type=Path)
    dgn = commands.add_parser("diagnose", help="find and model the physics the model left out")
    dgn.add_argument("recording", type=Path)
    dgn.add_argument("--rig", type=Path, required=True)
    dgn.add_argument("--out", type=Path, required=True, help="folder for diagnosis.json etc.")
    sim = commands.add_parser(
        "simulate", help="write a recording of the LTI model or of the virtual rig"
    )
    sim.add_argument("--rig", type=Path, required=True, help="the rig to simulate (truth)")
    sim.add_argument("--out", type=Path, required=True, help="new rosbag2 directory")
    sim.add_argument(
        "--max-pressure",
        type=float,
        nargs="+",
        default=[1.38e6],
        help="maximum master-cylinder pressures, Pa (one segment each)",
    )
    sim.add_argument("--pulsing-seconds", type=float, default=5.0)
    sim.add_argument("--seed", type=int, default=0)
    virtual_rig_cli.add_simulate_arguments(sim)
    virtual_rig_cli.add_cases_parser(commands)
    bench = commands.add_parser("benchmark", help="score the diagnosis blind on labelled cases")
    bench.add_argument("directory", type=Path, help="made by 'brake-hil cases'")
    bench.add_argument("--jobs", type=int, default=1)
    bench.add_argument("--json", type=Path)
    reg = commands.add_parser("regress", help="replay recordings through the model vs a baseline")
    reg.add_argument("recordings", type=Path, nargs="+")
    reg.add_argument("--baseline", type=Path, required=True, help="baseline JSON")
    reg.add_argument("--model", type=Path, help="model file (default: the baseline's)")
    reg.add_argument("--update", action="store_true", help="rewrite the baseline")
    reg.add_argument("--jobs", type=int, help="parallel replays (default: one per CPU)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``brake-hil`` console script."""
    args = build_parser().parse_args(argv)
    try:
        if args.command == "compare":
            run_compare(args.recording, args.rig, args.json, args.plot)
        elif args.command == "characterize":
            run_characterize(args.recording, args.rig, args.json)
        elif args.command == "diagnose":
            run_diagnose(args.recording, args.rig, args.out)
        elif args.command == "simulate" and virtual_rig_cli.uses_virtual_rig(args):
            virtual_rig_cli.run_virtual_simulate(args)
        elif args.command == "simulate":
            run_simulate(args.rig, args.out, args.max_pressure, args.pulsing_seconds, args.seed)
        elif args.command == "cases":
            virtual_rig_cli.run_cases(args)
        elif args.command == "benchmark":
            run_benchmark(args.directory, args.jobs, args.json)
        elif args.command == "regress":
            return run_regression(
                args.recordings, args.baseline, read_recording, args.model, args.update, args.jobs
            )
    except BrakeHilError as err:
        print(f"brake-hil {args.command}: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    return 0


if __name__ == "__main__":
    sys.exit(main())
