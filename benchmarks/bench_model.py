"""Speed of the seed's LTI caliper model: per-sample stepper and whole-recording batch.

What is measured (nominal rig ``config/rig_default.yaml``, caliper model with ``p_i`` input):

1. Stepper. ``CaliperStepper.step`` is timed call by call with ``time.perf_counter_ns`` on a
   rig-like input (5 Hz pulsing ``p_i`` about 1.08 MPa, 1 kHz samples); median, p99, p99.9
   and max in microseconds. Two references are timed the same way in the same run: a bare
   Python call of a trivial function (the floor: call plus timer overhead) and the numpy
   form of the same step (``transition @ state + ...`` on arrays). The garbage collector
   stays on, as in the node. Goal: median under 20 us.
2. Batch. ``simulate(discretize(caliper_state_space(params)), pressure)`` on the seed-like
   18 s input ``pulsing_profile((1.38e6, 2.07e6, 2.76e6))`` (18 000 samples), best of
   several repeats, as a real-time factor (18 s / wall time); ``discretize`` is timed on its
   own (the median is printed too: multithreaded OpenBLAS makes simulate's small complex
   matrix product jitter on a 2-core machine; OPENBLAS_NUM_THREADS and friends are printed
   when set, never changed). Accuracy is the NRMSE (RMS error / peak-to-peak, per output
   p_b, F_k, x_c) against the exact solution of the continuous system with the input
   linearly interpolated between samples, computed once in 40-digit decimal arithmetic
   (first-order hold is exact for such an input, and 40 digits make it exact to double
   precision; a Radau run at rtol 1e-10 takes ~6 minutes here and is less accurate than the
   batch, so it cannot serve). Reference: ``scipy.integrate.solve_ivp`` with Radau on the
   same continuous system (``jac=A``, ``max_step=1e-3``, ``np.interp`` input, equilibrium
   start, ``t_eval`` at the samples, ``atol = rtol * state scale``), one run per rung of an
   rtol ladder, stopping once its NRMSE is no worse than the batch's. The speed ratio is
   Radau's wall time over the batch's (discretize + simulate); if no rung reaches the
   batch's accuracy, the most accurate rung gives a lower bound. Goals: over 1000x real
   time, over 100x faster than solve_ivp.

Run from the repository root (about 70 s on 2 cores)::

    .venv/bin/python benchmarks/bench_model.py [--steps 100000] [--json FILE]
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
import decimal
from decimal import Decimal
import json
import os
from pathlib import Path
import platform
import sys
import time
from typing import Any

import numpy as np
import scipy
from scipy.integrate import solve_ivp

from brake_hil.physics.excitation import SEED_MAX_PRESSURES, pulsing_profile
from brake_hil.physics.lti_model import (
    SAMPLE_TIME,
    CaliperStepper,
    DiscreteModel,
    ModelOutput,
    StateSpace,
    caliper_state_space,
    discretize,
    simulate,
)
from brake_hil.physics.parameters import derive_parameters
from brake_hil.physics.rig import load_rig
from brake_hil.types import FloatArray

REPOSITORY = Path(__file__).resolve().parents[1]
DEFAULT_RIG = REPOSITORY / "config" / "rig_default.yaml"

STEP_MEDIAN_GOAL_US = 20.0
REAL_TIME_GOAL = 1000.0
RADAU_RATIO_GOAL = 100.0

STEPPER_MAX_PRESSURE = 1.38e6
"""Pulsing about (1 - 0.22) * 1.38 MPa = 1.08 MPa, the seed's lowest level."""
WARM_UP_STEPS = 2000
DEFAULT_RTOLS = (1e-6, 1e-8, 1e-9)
"""Radau rtol ladder; each rung costs ~4 s, ~25 s and ~35 s here."""
OUTPUT_NAMES = ("p_b", "F_k", "x_c")
BLAS_VARIABLES = ("OPENBLAS_CORETYPE", "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")
"""Environment printed when set (never changed here): BLAS threads move simulate's time."""
REFERENCE_DIGITS = 40
"""Decimal digits of the exact reference (60 gives the same doubles)."""


@dataclass(frozen=True)
class CallTiming:
    """Per-call wall time of one callable (microseconds)."""

    name: str
    median_us: float
    p99_us: float
    p999_us: float
    max_us: float


@dataclass(frozen=True)
class RadauRun:
    """One solve_ivp Radau run against the exact reference."""

    rtol: float
    wall_s: float
    nfev: int
    nrmse: tuple[float, ...]  # per output p_b, F_k, x_c
    batch_speedup: float  # Radau wall time / batch (discretize + simulate) wall time


# --- 1. per-sample stepper -------------------------------------------------------------


def _trivial(value: float) -> float:
    return value


class ListStepper:
    """The step of CaliperStepper written with plain Python lists (the alternative it beat)."""

    def __init__(self, model: DiscreteModel) -> None:
        self._model = model
        self._transition = model.transition.tolist()
        self._input_previous = model.input_previous.tolist()
        self._input_current = model.input_current.tolist()
        self._output = model.output_matrix[:3].tolist()
        self._state: list[float] | None = None
        self._previous_input = 0.0

    def step(self, pressure: float) -> ModelOutput:
        """Advance one sample; return the outputs as CaliperStepper.step does."""
        state = self._state
        if state is None:
            state = self._model.equilibrium(pressure).tolist()
        else:
            previous = self._previous_input
            state = [
                sum(a * z for a, z in zip(row, state)) + g_prev * previous + g_now * pressure
                for row, g_prev, g_now in zip(
                    self._transition, self._input_previous, self._input_current
                )
            ]
        self._state = state
        self._previous_input = pressure
        p_b, f_k, x_c = (sum(c * z for c, z in zip(row, state)) for row in self._output)
        return ModelOutput(p_b, f_k, x_c)


def time_calls(name: str, function: Callable[[float], object], inputs: list[float]) -> CallTiming:
    """Time ``function(value)`` for each input, one perf_counter_ns pair around each call."""
    clock = time.perf_counter_ns
    durations = [0] * len(inputs)
    for index, value in enumerate(inputs):
        start = clock()
        function(value)
        durations[index] = clock() - start
    micro = np.asarray(durations, dtype=float) / 1000.0
    p99, p999 = np.percentile(micro, [99.0, 99.9])
    return CallTiming(name, float(np.median(micro)), float(p99), float(p999), float(micro.max()))


def stepper_input(steps: int) -> list[float]:
    """``steps`` samples of 5 Hz pulsing p_i about 1.08 MPa at 1 kHz (after warm-up)."""
    total = steps + WARM_UP_STEPS
    _, pressure = pulsing_profile(
        (STEPPER_MAX_PRESSURE,), ramp_s=0.1, pulsing_s=total * SAMPLE_TIME
    )
    return [float(value) for value in pressure[-total:]]


def bench_stepper(model: DiscreteModel, steps: int) -> list[CallTiming]:
    """Floor, CaliperStepper.step and the plain-list step, each over ``steps`` calls."""
    inputs = stepper_input(steps)
    warm_up, timed = inputs[:WARM_UP_STEPS], inputs[WARM_UP_STEPS:]
    stepper = CaliperStepper(model)
    list_stepper = ListStepper(model)
    for value in warm_up:
        _trivial(value)
        stepper.step(value)
        list_stepper.step(value)
    results = [
        time_calls("bare Python call (floor)", _trivial, timed),
        time_calls("CaliperStepper.step", stepper.step, timed),
        time_calls("plain-list step (alternative)", list_stepper.step, timed),
    ]
    lists = np.asarray(stepper.step(timed[-1]))
    arrays = np.asarray(list_stepper.step(timed[-1]))
    if not np.allclose(lists, arrays, rtol=1e-9, atol=0.0):
        raise RuntimeError(f"stepper and plain-list step disagree: {lists} vs {arrays}")
    return results


# --- 2. batch simulation and its references ----------------------------------------------


def wall_times(function: Callable[[], object], repeats: int) -> FloatArray:
    """Wall time (s) of each of ``repeats`` calls."""
    times = np.empty(repeats)
    for index in range(repeats):
        start = time.perf_counter()
        function()
        times[index] = time.perf_counter() - start
    return times


Matrix = list[list[Decimal]]


def _matmul(left: Matrix, right: Matrix) -> Matrix:
    columns = list(zip(*right))
    return [
        [sum((a * b for a, b in zip(row, column)), Decimal(0)) for column in columns]
        for row in left
    ]


def _expm_decimal(matrix: Matrix) -> Matrix:
    """Matrix exponential at the current decimal precision.

    Taylor series after scaling the norm below 1/2, then squaring (the digits to spare absorb
    the squarings' error growth).
    """
    norm = max(sum((abs(value) for value in row), Decimal(0)) for row in matrix)
    squarings = 0
    while norm > Decimal("0.5"):
        norm /= 2
        squarings += 1
    factor = Decimal(2) ** squarings
    scaled = [[value / factor for value in row] for row in matrix]
    size = len(matrix)
    result = [[Decimal(int(i == j)) for j in range(size)] for i in range(size)]
    term = [row[:] for row in result]
    negligible = Decimal(10) ** -(decimal.getcontext().prec + 5)
    for order in range(1, 200):
        term = [[value / order for value in row] for row in _matmul(term, scaled)]
        result = [[a + b for a, b in zip(r, t)] for r, t in zip(result, term)]
        if max(abs(value) for row in term for value in row) < negligible:
            break
    for _ in range(squarings):
        result = _matmul(result, result)
    return result


def _solve_decimal(matrix: Matrix, rhs: list[Decimal]) -> list[Decimal]:
    """Gaussian elimination with partial pivoting at the current decimal precision."""
    size = len(rhs)
    rows = [row[:] + [value] for row, value in zip(matrix, rhs)]
    for column in range(size):
        pivot = max(range(column, size), key=lambda r: abs(rows[r][column]))
        rows[column], rows[pivot] = rows[pivot], rows[column]
        for r in range(column + 1, size):
            factor = rows[r][column] / rows[column][column]
            rows[r] = [a - factor * b for a, b in zip(rows[r], rows[column])]
    solution = [Decimal(0)] * size
    for r in reversed(range(size)):
        known = sum((rows[r][c] * solution[c] for c in range(r + 1, size)), Decimal(0))
        solution[r] = (rows[r][size] - known) / rows[r][r]
    return solution


def exact_reference(
    system: StateSpace, pressure: FloatArray, sample_time: float, digits: int = REFERENCE_DIGITS
) -> FloatArray:
    """Outputs (m, N) of ``x' = A x + B u`` with ``u`` linear between samples.

    From the equilibrium at ``u[0]``: first-order hold in ``digits``-digit decimal arithmetic,
    stepped sample by sample. Exact to double precision and independent of what
    :func:`simulate` uses (scipy's expm, the modal split, lfilter).
    """
    with decimal.localcontext() as context:
        context.prec = digits
        scale = [Decimal(repr(float(value))) for value in system.state_scale]  # 1e-6 exactly
        A = [
            [Decimal(float(a)) * scale[j] / scale[i] for j, a in enumerate(row)]
            for i, row in enumerate(system.state_matrix)
        ]
        B = [Decimal(float(b)) / scale[i] for i, b in enumerate(system.input_matrix[:, 0])]
        C = [
            [Decimal(float(c)) * scale[j] for j, c in enumerate(row)]
            for row in system.output_matrix
        ]
        n = len(B)
        h = Decimal(float(sample_time))
        # expm([[A, B, 0], [0, 0, 1/h], [0, 0, 0]] h) = [[Phi, G1, G2], [0, 1, 1], [0, 0, 1]]
        block = [[Decimal(0)] * (n + 2) for _ in range(n + 2)]
        for i in range(n):
            block[i][:n] = [a * h for a in A[i]]
            block[i][n] = B[i] * h
        block[n][n + 1] = Decimal(1)
        exponential = _expm_decimal(block)
        transition = [row[:n] for row in exponential[:n]]
        gamma_now = [row[n + 1] for row in exponential[:n]]
        gamma_previous = [row[n] - row[n + 1] for row in exponential[:n]]
        u = [Decimal(float(value)) for value in pressure]
        state = _solve_decimal(A, [-b * u[0] for b in B])
        outputs = np.empty((len(C), len(u)))
        for k, now in enumerate(u):
            if k:
                previous = u[k - 1]
                state = [
                    sum((a * z for a, z in zip(row, state)), g_prev * previous + g_now * now)
                    for row, g_prev, g_now in zip(transition, gamma_previous, gamma_now)
                ]
            for m, row in enumerate(C):
                outputs[m, k] = float(sum((c * z for c, z in zip(row, state)), Decimal(0)))
        return outputs


def nrmse(outputs: FloatArray, reference: FloatArray) -> tuple[float, ...]:
    """RMS error / peak-to-peak of the reference, per output row."""
    rms = np.sqrt(np.mean((outputs - reference) ** 2, axis=1))
    return tuple(float(value) for value in rms / np.ptp(reference, axis=1))


def run_radau(
    system: StateSpace, times: FloatArray, pressure: FloatArray, rtol: float
) -> tuple[FloatArray, float, int]:
    """Outputs (3, N), wall time (s) and nfev of solve_ivp Radau at ``rtol``."""
    A = system.state_matrix
    B = system.input_matrix[:, 0]

    def rhs(t: float, x: FloatArray) -> FloatArray:
        return A @ x + B * np.interp(t, times, pressure)

    start = time.perf_counter()
    x0 = -np.linalg.solve(A, B * pressure[0])
    solution = solve_ivp(
        rhs,
        (float(times[0]), float(times[-1])),
        x0,
        method="Radau",
        t_eval=times,
        rtol=rtol,
        atol=rtol * system.state_scale,
        jac=A,
        max_step=1e-3,
    )
    wall = time.perf_counter() - start
    if not solution.success:
        raise RuntimeError(f"solve_ivp Radau failed at rtol {rtol:g}: {solution.message}")
    return system.output_matrix @ solution.y, wall, int(solution.nfev)


# --- report ------------------------------------------------------------------------------


def machine() -> dict[str, Any]:
    """Platform, interpreter and library versions, CPU count."""
    info: dict[str, Any] = {
        "platform": platform.platform(),
        "python": f"{platform.python_implementation()} {platform.python_version()}",
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "cpu_count": os.cpu_count(),
    }
    for name in BLAS_VARIABLES:
        if name in os.environ:
            info[name] = os.environ[name]
    return info


def verdict(passed: bool) -> str:
    """PASS or FAIL."""
    return "PASS" if passed else "FAIL"


def _fmt_nrmse(values: Sequence[float]) -> str:
    return "  ".join(f"{value:9.2e}" for value in values)


def parse_arguments(argv: Sequence[str] | None) -> argparse.Namespace:
    """Command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100_000, help="stepper calls timed")
    parser.add_argument("--json", type=Path, help="also write the figures to this JSON file")
    parser.add_argument("--rig", type=Path, default=DEFAULT_RIG, help="rig YAML file")
    parser.add_argument("--repeats", type=int, default=20, help="batch repeats (best taken)")
    parser.add_argument(
        "--rtols",
        type=lambda text: tuple(float(part) for part in text.split(",")),
        default=DEFAULT_RTOLS,
        help="Radau rtol ladder, comma separated, loosest first",
    )
    arguments = parser.parse_args(argv)
    if arguments.steps < 1 or arguments.repeats < 1:
        parser.error("--steps and --repeats must be positive")
    return arguments


def main(argv: Sequence[str] | None = None) -> int:
    """Run both benchmarks, print the table, optionally write JSON."""
    arguments = parse_arguments(argv)
    info = machine()
    print("brake_hil model benchmark")
    print(
        f"machine  {info['platform']} | {info['python']} | numpy {info['numpy']} | "
        f"scipy {info['scipy']} | {info['cpu_count']} CPUs"
    )
    blas = [f"{name}={info[name]}" for name in BLAS_VARIABLES if name in info]
    if blas:
        print(f"         {' '.join(blas)}")
    rig = load_rig(arguments.rig)
    print(f"rig      {arguments.rig} ({rig.name})")
    system = caliper_state_space(derive_parameters(rig))
    model = discretize(system)

    print(f"\n1. stepper: {arguments.steps} calls, 5 Hz pulsing p_i about 1.08 MPa (us per call)")
    timings = bench_stepper(model, arguments.steps)
    print(f"   {'call':<28}{'median':>8}{'p99':>8}{'p99.9':>8}{'max':>9}")
    for timing in timings:
        print(
            f"   {timing.name:<28}{timing.median_us:8.2f}{timing.p99_us:8.2f}"
            f"{timing.p999_us:8.2f}{timing.max_us:9.1f}"
        )
    floor, stepper, list_step = timings
    step_passed = stepper.median_us < STEP_MEDIAN_GOAL_US
    list_ratio = list_step.median_us / stepper.median_us
    print(
        f"   goal: step median < {STEP_MEDIAN_GOAL_US:g} us: {stepper.median_us:.2f} us "
        f"{verdict(step_passed)}; plain-list step / CaliperStepper = {list_ratio:.2f}x; "
        f"step / floor = {stepper.median_us / floor.median_us:.0f}x"
    )

    times, pressure = pulsing_profile(SEED_MAX_PRESSURES)
    duration = pressure.size * SAMPLE_TIME
    repeats = arguments.repeats
    print(
        f"\n2. batch: {pressure.size} samples = {duration:g} s at 1 kHz, "
        f"best of {repeats} (wall ms, real-time factor)"
    )
    discretize_s = float(wall_times(lambda: discretize(system), repeats).min())
    simulate_times = wall_times(lambda: simulate(model, pressure), repeats)
    simulate_s = float(simulate_times.min())
    simulate_median_s = float(np.median(simulate_times))
    batch_s = discretize_s + simulate_s
    real_time = duration / simulate_s
    rt_passed = real_time > REAL_TIME_GOAL
    print(f"   {'discretize':<24}{discretize_s * 1e3:9.2f} ms")
    print(
        f"   {'simulate':<24}{simulate_s * 1e3:9.2f} ms {real_time:9.0f}x real time   "
        f"goal > {REAL_TIME_GOAL:g}x {verdict(rt_passed)}"
    )
    print(f"   {'simulate, median':<24}{simulate_median_s * 1e3:9.2f} ms")
    print(f"   {'discretize + simulate':<24}{batch_s * 1e3:9.2f} ms {duration / batch_s:9.0f}x")

    start = time.perf_counter()
    reference = exact_reference(system, pressure, SAMPLE_TIME)
    reference_s = time.perf_counter() - start
    batch_nrmse = nrmse(simulate(model, pressure), reference)
    print(
        f"   accuracy: NRMSE vs exact {REFERENCE_DIGITS}-digit first-order-hold solution "
        f"({reference_s:.1f} s, once)"
    )
    print(f"   {'':<24}{'p_b':>9}  {'F_k':>9}  {'x_c':>9}")
    print(f"   {'batch':<24}{_fmt_nrmse(batch_nrmse)}")

    print("   solve_ivp Radau, jac=A, max_step 1 ms, atol = rtol * state scale (one run each):")
    print(f"   {'rtol':<8}{'wall s':>8}{'nfev':>10}   NRMSE p_b / F_k / x_c{'':>9}batch faster")
    runs: list[RadauRun] = []
    for rtol in sorted(arguments.rtols, reverse=True):
        outputs, wall, nfev = run_radau(system, times, pressure, rtol)
        run = RadauRun(rtol, wall, nfev, nrmse(outputs, reference), wall / batch_s)
        runs.append(run)
        print(
            f"   {rtol:<8.0e}{wall:8.2f}{nfev:10d}   {_fmt_nrmse(run.nrmse)}"
            f"{run.batch_speedup:10.0f}x"
        )
        if max(run.nrmse) <= max(batch_nrmse):
            break
    equal = next((run for run in runs if max(run.nrmse) <= max(batch_nrmse)), None)
    chosen = equal if equal is not None else min(runs, key=lambda run: max(run.nrmse))
    ratio_passed = chosen.batch_speedup > RADAU_RATIO_GOAL
    if equal is not None:
        print(
            f"   equal accuracy at rtol {chosen.rtol:.0e}: batch {chosen.batch_speedup:.0f}x "
            f"faster than Radau   goal > {RADAU_RATIO_GOAL:g}x {verdict(ratio_passed)}"
        )
    else:
        print(
            f"   equal accuracy not reached (best Radau NRMSE {max(chosen.nrmse):.1e} at rtol "
            f"{chosen.rtol:.0e}, batch {max(batch_nrmse):.1e}):"
        )
        print(
            f"   batch >= {chosen.batch_speedup:.0f}x faster than Radau at equal accuracy   "
            f"goal > {RADAU_RATIO_GOAL:g}x {verdict(ratio_passed)}"
        )

    if arguments.json is not None:
        figures = {
            "machine": info,
            "rig": str(arguments.rig),
            "stepper": {
                "steps": arguments.steps,
                "timings": [asdict(timing) for timing in timings],
                "list_over_stepper": list_ratio,
                "goal_median_us": STEP_MEDIAN_GOAL_US,
                "goal_passed": step_passed,
            },
            "batch": {
                "samples": int(pressure.size),
                "duration_s": duration,
                "repeats": repeats,
                "discretize_s": discretize_s,
                "simulate_s": simulate_s,
                "simulate_median_s": simulate_median_s,
                "real_time_factor": real_time,
                "real_time_factor_with_discretize": duration / batch_s,
                "nrmse": dict(zip(OUTPUT_NAMES, batch_nrmse)),
                "reference": f"exact first-order hold, {REFERENCE_DIGITS} decimal digits",
                "reference_s": reference_s,
                "goal_real_time_factor": REAL_TIME_GOAL,
                "goal_passed": rt_passed,
            },
            "radau": {
                "runs": [
                    {**asdict(run), "nrmse": dict(zip(OUTPUT_NAMES, run.nrmse))} for run in runs
                ],
                "equal_accuracy_reached": equal is not None,
                "batch_speedup": chosen.batch_speedup,
                "batch_speedup_is_lower_bound": equal is None,
                "goal_speedup": RADAU_RATIO_GOAL,
                "goal_passed": ratio_passed,
            },
        }
        arguments.json.write_text(json.dumps(figures, indent=2) + "\n", encoding="utf-8")
        print(f"\nfigures written to {arguments.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
