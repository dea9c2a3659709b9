"""Synthetic ``p_i`` chains of every excitation kind, with the segments they are built of."""

from __future__ import annotations

import numpy as np

from brake_hil.types import FloatArray

RATE = 1000.0  # Hz


def _sweep(duration: float, f0: float, f1: float, law: str) -> FloatArray:
    """Phase (rad) of a sweep from ``f0`` to ``f1`` (Hz) over ``duration`` (s)."""
    t = np.arange(int(round(duration * RATE))) / RATE
    if law == "log":
        k = np.log(f1 / f0) / duration
        return 2.0 * np.pi * f0 * (np.exp(k * t) - 1.0) / k
    return 2.0 * np.pi * (f0 * t + 0.5 * (f1 - f0) / duration * t**2)


def _abs_train(
    duration: float, level: float, depth: float, rng: np.random.Generator
) -> FloatArray:
    """ABS-like train: from ``level`` (Pa), dumps of ``depth`` at irregular 70-200 ms."""
    out: list[FloatArray] = []
    total = int(round(duration * RATE))
    while sum(p.size for p in out) < total:
        period = rng.uniform(0.07, 0.2)
        n = int(period * RATE)
        t = np.arange(n) / n
        shape = np.where(t < 0.15, t / 0.15, np.where(t < 0.45, 1.0, 1.0 - (t - 0.45) / 0.55))
        out.append(level - depth * shape)
    return np.concatenate(out)[:total]


def procedure(seed: int = 0, law: str = "linear") -> tuple[FloatArray, FloatArray, list[tuple]]:
    """Time (s), ``p_i`` (Pa, with noise) and the expected ``(kind, t_start, t_end, info)``.

    Idle, ramp, 5 Hz pulsing, a 5-25 Hz sweep, hold, slow ramp, hold, step release, hold,
    an ABS-like train, hold, step release, hold.
    """
    rng = np.random.default_rng(seed)
    mean, amp = 1.0e6, 0.3e6
    parts: list[FloatArray] = []

    def span(duration: float) -> FloatArray:
        return np.arange(int(round(duration * RATE))) / RATE

    parts.append(np.zeros(int(RATE)))  # 0-1 idle
    parts.append(mean * span(1.0))  # 1-2 ramp
    pulse = 2.0 * np.pi * 5.0 * span(3.0)
    parts.append(mean + amp * np.sin(pulse))  # 2-5 pulsing 5 Hz
    parts.append(mean + amp * np.sin(_sweep(10.0, 5.0, 25.0, law)))  # 5-15 sweep
    parts.append(np.full(int(RATE), mean))  # 15-16 hold
    parts.append(mean + 0.5e6 * span(3.0))  # 16-19 ramp 0.5 MPa/s
    parts.append(np.full(int(RATE), 2.5e6))  # 19-20 hold
    parts.append(np.full(int(RATE), 1.5e6))  # 20-21 step release at 20, hold
    parts[-1][:20] = np.linspace(2.5e6, 1.5e6, 20)
    parts.append(_abs_train(3.0, 1.5e6, 0.6e6, rng))  # 21-24 ABS-like train
    parts.append(np.full(int(RATE), 1.5e6))  # 24-25 hold
    release = np.full(2 * int(RATE), 0.3e6)  # 25-27 step release to a low hold
    release[:20] = np.linspace(1.5e6, 0.3e6, 20)  # (above 0: the sensors clip at 0)
    parts.append(release)
    pressure = np.concatenate(parts) + rng.normal(0.0, 1.5e3, sum(p.size for p in parts))
    time = np.arange(pressure.size) / RATE
    expected = [
        ("idle", 0.0, 1.0, {}),
        ("ramp", 1.0, 2.0, {"rate_pa_per_s": mean}),
        ("pulsing", 3.0, 5.0, {"frequency_hz": 5.0}),  # its first second is settling
        ("sweep", 5.0, 15.0, {"f0_hz": 5.0, "f1_hz": 25.0, "law": law}),
        ("hold", 15.0, 16.0, {"level_pa": mean}),
        ("ramp", 16.0, 19.0, {"rate_pa_per_s": 0.5e6}),
        ("hold", 19.0, 20.0, {"level_pa": 2.5e6}),
        ("step", 20.0, 20.02, {"direction": "release"}),
        ("hold", 20.02, 21.0, {"level_pa": 1.5e6}),
        ("modulated", 21.0, 24.0, {}),
        ("hold", 24.0, 25.0, {"level_pa": 1.5e6}),
        ("step", 25.0, 25.02, {"direction": "release"}),
        ("hold", 25.02, 27.0, {"level_pa": 0.3e6}),
    ]
    return time, pressure, expected


def lti_recording(rig_path: str, time: FloatArray, pressure: FloatArray, seed: int = 0):
    """The rig file's LTI model's own recording of ``pressure`` (Pa), with the DAQ's noise.

    The model is derived where :func:`compare_segments` derives it (the operating point of
    the segments that are neither idle nor steady pulsing), so compare holds it against
    itself.
    """
    from pathlib import Path

    from brake_hil.analysis import signals
    from brake_hil.analysis.comparison import predict
    from brake_hil.analysis.recording import Recording
    from brake_hil.analysis.segment_comparison import operating_pressure
    from brake_hil.analysis.segmentation import find_segments
    from brake_hil.physics.measurement import SENSORS, measure
    from brake_hil.physics.parameters import derive_parameters
    from brake_hil.physics.rig import load_rig

    rig = load_rig(Path(rig_path))
    rng = np.random.default_rng(seed)
    measured_p = measure(pressure, SENSORS["p_i"], rng)
    filtered = signals.lowpass(measured_p, RATE)
    segments = find_segments(time, filtered, RATE, rig.excitation_hz)
    params = derive_parameters(rig, operating_pressure(filtered, time, segments))
    outputs = predict(pressure, params, 1.0 / RATE)
    return rig, Recording(
        path=Path(f"lti-{seed}"),
        time=time,
        master_cylinder_pressure=measured_p,
        bore_pressure=measure(outputs["p_b"], SENSORS["p_b"], rng),
        block_force=measure(outputs["F_k"], SENSORS["F_k"], rng),
        caliper_displacement=measure(outputs["x_c"], SENSORS["x_c"], rng),
    )
