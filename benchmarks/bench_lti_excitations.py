"""The LTI model against itself on every excitation: how far ``compare`` lands from exact.

For each excitation (pulsing, ramp, sweep, procedure) the LTI model's own recording is
written (``brake-hil simulate --engine lti --excitation KIND``, the DAQ's noise, seed
``--seed``) from ``config/rig_default.yaml`` at the paper's three pressures, and compared
with the model (``compare_segments``). Per kind, the largest distance from exact of every
figure of merit over every scored segment and channel: ratios (ptp, a ramp's map slope, a
sweep's gain, a step's rise time) from 100 %, errors (tau/T, stick, level, loop width, a
step's overshoot) from 0, a sweep's worst band and mean phase; and apart, the largest NRMSE
(in %: the DAQ's noise against the channel's range, not the model's error). Run from a
checkout::

    .venv/bin/python benchmarks/bench_lti_excitations.py --seed 11 --pulsing-seconds 5
"""

from __future__ import annotations

import argparse
from pathlib import Path
import tempfile

from brake_hil.analysis.segment_comparison import compare_segments
from brake_hil.app.simulate import LTI_EXCITATIONS, run_simulate
from brake_hil.io.recording_reader import read_recording
from brake_hil.physics.rig import load_rig

RIG = Path(__file__).resolve().parents[1] / "config" / "rig_default.yaml"
RATIOS = ("ptp_ratio_pct", "map_gain_ratio_pct", "mean_gain_ratio_pct", "rise_time_ratio_pct")
ERRORS = (
    "tau_over_T_pct",
    "stick_error_pct",
    "level_error_pct",
    "loop_width_error_pct",
    "overshoot_error_pct",
    "worst_error_pct",
    "mean_phase_error_deg",
)


def off_exact(metrics: dict[str, object]) -> dict[str, float]:
    """Each figure of merit's distance from exact (NRMSE as %)."""
    values = {k: float(v) for k, v in metrics.items() if isinstance(v, int | float)}
    off = {k: abs(values[k] - 100.0) for k in RATIOS if k in values}
    off.update({k: abs(values[k]) for k in ERRORS if k in values})
    if "nrmse" in values:
        off["nrmse_pct"] = 100.0 * values["nrmse"]
    return off


def main() -> None:
    """Print one row per excitation: segments scored, the worst figure and where."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=11)
    parser.add_argument("--pulsing-seconds", type=float, default=5.0)
    args = parser.parse_args()
    print(
        "| excitation | length | segments scored | worst figure (off exact) | where | "
        "largest NRMSE (the DAQ's noise) |"
    )
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        for kind in LTI_EXCITATIONS:
            out = Path(folder) / kind
            written = run_simulate(
                RIG, out, (1.38e6, 2.07e6, 2.76e6), args.pulsing_seconds, args.seed, kind
            )
            comparison = compare_segments(read_recording(out), load_rig(RIG))
            scored = [s for s in comparison.segments if s.metrics]
            worst, noise = (0.0, "", ""), 0.0
            for s in scored:
                for channel, metrics in s.metrics.items():
                    for key, value in off_exact(metrics).items():
                        if key == "nrmse_pct":
                            noise = max(noise, value)
                            continue
                        where = f"{s.segment.kind} {s.segment.t_start:.1f} s, {channel}"
                        worst = max(worst, (value, key, where))
            kinds = ", ".join(dict.fromkeys(s.segment.kind for s in scored))
            print(
                f"| {kind} | {written.duration_s:.1f} s | {len(scored)} ({kinds}) | "
                f"{worst[1]} {worst[0]:.3f} | {worst[2]} | {noise:.2f} % |"
            )


if __name__ == "__main__":
    main()
