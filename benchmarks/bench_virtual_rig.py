"""Virtual rig: speed (seconds per simulated second) and accuracy against a tighter solve.

Run: ``.venv/bin/python benchmarks/bench_virtual_rig.py [--quick] [--method BDF|LSODA|Radau]``.

Speed: the seed's 18 s recording (ramps to 1.38, 2.07, 2.76 MPa, 5 s of 5 Hz pulsing each)
with no effect, each effect alone at strength 1, every effect at once, and every effect with
the solenoid (air-driven) input. Accuracy: 4 s at 2.76 MPa (the most nonlinear segment)
solved with the default settings and with the seed's own setting (a stiff variable-step
solve at ``rtol = 1e-3``, MATLAB's default, 1 ms maximum step), each against a reference at
``rtol = 1e-9`` and 0.1 ms maximum step; NRMSE is the RMS error over the reference's
peak-to-peak, per channel. Wall-clock figures depend on the machine and its load; the CPU
seconds of this process (``time.process_time``) are the steadier figure on a shared machine.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import time

import numpy as np

from brake_hil.physics.rig import load_rig
from brake_hil.virtual_rig import (
    EFFECTS,
    make_effect,
    seed_pulsing,
    simulate_rig,
    solenoid_pulsing,
)
from brake_hil.virtual_rig.simulator import RELATIVE_TOLERANCE, SOLVER_METHOD

RIG = Path(__file__).resolve().parents[1] / "config" / "rig_default.yaml"
CHANNELS = ("p_b", "F_k", "x_c")


def _nrmse(value: np.ndarray, reference: np.ndarray) -> float:
    return float(np.sqrt(np.mean((value - reference) ** 2)) / np.ptp(reference))


def speed(method: str, pulsing_s: float) -> None:
    """Print wall and CPU seconds per simulated second of each configuration (``method``)."""
    rig = load_rig(RIG)
    pressures = (1.38e6, 2.07e6, 2.76e6)
    excitation = seed_pulsing(pressures, pulsing_s=pulsing_s)
    every = [make_effect(name) for name in EFFECTS]
    configurations = [("no effect", [], excitation)]
    configurations += [(name, [make_effect(name)], excitation) for name in EFFECTS]
    configurations.append(("all effects", every, excitation))
    air = solenoid_pulsing(rig, pressures, pulsing_s=pulsing_s)
    configurations.append(("no effect, solenoid (air-driven)", [], air))
    configurations.append(("all effects, solenoid (air-driven)", every, air))
    print(
        f"speed: {method}, rtol {RELATIVE_TOLERANCE:g}, max step 1 ms, "
        f"{excitation.duration:.1f} s recordings"
    )
    print(
        f"{'configuration':38s}{'wall s':>8s}{'cpu s':>7s}{'cpu s/sim s':>13s}"
        f"{'f evals':>9s}{'jac':>6s}"
    )
    for label, effects, drive in configurations:
        began, began_cpu = time.perf_counter(), time.process_time()
        run = simulate_rig(rig, effects, drive, method=method)
        seconds, cpu = time.perf_counter() - began, time.process_time() - began_cpu
        print(
            f"{label:38s}{seconds:8.2f}{cpu:7.2f}{cpu / drive.duration:13.3f}"
            f"{run.solver.rhs_evaluations:9d}{run.solver.jacobian_evaluations:6d}"
        )


def accuracy(method: str) -> None:
    """Print each case's NRMSE per channel against a tight reference solve, per setting."""
    rig = load_rig(RIG)
    excitation = seed_pulsing((2.76e6,), pulsing_s=3.0)
    cases = [
        ("no effect", []),
        ("seal_stick_slip", [make_effect("seal_stick_slip")]),
        ("all effects", [make_effect(name) for name in EFFECTS]),
    ]
    settings = [
        (
            f"default ({method}, rtol {RELATIVE_TOLERANCE:g}, 1 ms)",
            method,
            RELATIVE_TOLERANCE,
            1e-3,
        ),
        ("seed's setting (BDF, rtol 1e-3, 1 ms)", "BDF", 1e-3, 1e-3),
    ]
    print("\naccuracy: NRMSE against BDF at rtol 1e-9, max step 0.1 ms (4 s at 2.76 MPa)")
    print(
        f"{'case':18s}{'setting':44s}" + "".join(f"{c:>10s}" for c in CHANNELS) + f"{'cpu s':>8s}"
    )
    for label, effects in cases:
        reference = simulate_rig(rig, effects, excitation, rtol=1e-9, max_step=1e-4)
        for name, solver, rtol, max_step in settings:
            began = time.process_time()
            run = simulate_rig(
                rig, effects, excitation, method=solver, rtol=rtol, max_step=max_step
            )
            seconds = time.process_time() - began
            errors = [_nrmse(run.true()[c], reference.true()[c]) for c in CHANNELS]
            print(
                f"{label:18s}{name:44s}"
                + "".join(f"{e:10.1e}" for e in errors)
                + f"{seconds:8.2f}"
            )


def main() -> None:
    """Parse the arguments, then run the speed and the accuracy benchmark."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", default=SOLVER_METHOD, choices=("BDF", "Radau", "LSODA"))
    parser.add_argument("--quick", action="store_true", help="6 s recordings instead of 18 s")
    args = parser.parse_args()
    speed(args.method, 1.0 if args.quick else 5.0)
    accuracy(args.method)


if __name__ == "__main__":
    main()
