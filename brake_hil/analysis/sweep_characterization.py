"""The seal's stiffness and damping against frequency from a sweep: Table 3 over 5-25 Hz.

A steady segment is characterised at its one frequency (:mod:`characterization`): the seal
displacement ``x_s = F_k / k_k - x_c`` and the seal force of the piston balance (eq. 21e)
``F_s = A_ep p_b - F_k - M_p x_p''``, then ``k_eh + j w c_eh = F_s / X_s`` at the
fundamental. A sweep passes through every frequency in turn, so the same quantities are
taken per frequency band (:func:`segment_metrics.band_windows`: 1 Hz bands on a linear
sweep, a tenth of a decade on a log one, at least four cycles each) by least squares,

    F_s(t) = a + b t + k_eh x_s(t) + c_eh x_s'(t),

which for a sine over whole cycles is exactly ``Re(F_s / X_s)`` and ``Im(F_s / X_s) / w``
(``x_s`` and ``x_s'`` are orthogonal there) and stays exact for the LTI seal while the
frequency moves within the band. Derivatives are central differences of the 30 Hz
low-passed signals.

Each point's uncertainty is the fit's standard error (one sigma), with the residual's
samples counted as independent only every ``1 / (2 x 30 Hz)`` (the low-pass leaves that
many independent values per second); ``k_eh*`` and ``eta_eh`` carry it on to first order.
For the LTI seal the points are the rig file's ``k_eh`` and ``c_eh`` at every frequency;
for a seal that sticks and slips they are its equivalent linear stiffness and damping at
that frequency and amplitude.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
import math

import numpy as np

from brake_hil.analysis import signals
from brake_hil.analysis.characterization import SegmentCharacterization, characterize
from brake_hil.analysis.comparison import conditioned_channels
from brake_hil.analysis.recording import Recording
from brake_hil.analysis.segment_metrics import band_windows
from brake_hil.analysis.segmentation import Segment, find_segments
from brake_hil.errors import NoSteadyPulsingError, RecordingError, SignalError
from brake_hil.physics.parameters import piston_area, seal_properties
from brake_hil.physics.rig import Rig
from brake_hil.types import FloatArray

__all__ = [
    "BandCharacterization",
    "RecordingCharacterization",
    "SweepCharacterization",
    "characterize_recording",
    "characterize_sweep",
]

LOWPASS_HZ = 30.0
"""The conditioning's cut-off: sets how many residual samples are independent."""


@dataclass(frozen=True)
class BandCharacterization:
    """The seal over one frequency band of a sweep (SI; ``*_sigma``: one standard error)."""

    frequency_hz: float
    t_start: float  # s
    t_end: float  # s
    seal_displacement_amplitude: float  # X_s, m (half the peak-to-peak of x_s in the band)
    k_eh: float  # N/m
    k_eh_sigma: float
    c_eh: float  # N s/m
    c_eh_sigma: float
    k_eh_star: float  # 0.5 k_eh / k_s
    k_eh_star_sigma: float
    eta_eh: float  # c_eh w / k_eh
    eta_eh_sigma: float


@dataclass(frozen=True)
class SweepCharacterization:
    """Every band of one sweep segment."""

    segment: Segment
    bands: list[BandCharacterization]

    def as_dict(self) -> dict[str, object]:
        """JSON: the sweep (kind, times, ``f0_hz``, ``f1_hz``, ``law``) and its ``bands``."""
        return {**self.segment.as_dict(), "bands": [asdict(b) for b in self.bands]}


def _seal_signals(
    time: FloatArray, filtered: dict[str, FloatArray], rig: Rig
) -> tuple[FloatArray, FloatArray]:
    """Seal displacement ``x_s`` (m) and seal force ``F_s`` (N) over the whole recording."""
    piston = filtered["F_k"] / rig.block_stiffness  # x_p = F_k / k_k
    acceleration = np.gradient(np.gradient(piston, time), time)
    seal_displacement = piston - filtered["x_c"]
    seal_force = (
        piston_area(rig) * filtered["p_b"] - filtered["F_k"] - rig.piston_mass * acceleration
    )
    return seal_displacement, seal_force


def _band(
    time: FloatArray,
    seal_displacement: FloatArray,
    seal_force: FloatArray,
    band: tuple[float, float, float],
    static_stiffness: float,
) -> BandCharacterization:
    """Least squares of the seal force on ``x_s`` and ``x_s'`` over one band."""
    centre, start, end = band
    part = signals.segment_slice(time, start, end)
    t = time[part]
    x = seal_displacement[part]
    velocity = np.gradient(seal_displacement, time)[part]
    basis = np.column_stack([np.ones_like(t), t - t.mean(), x, velocity])
    force = seal_force[part]
    coefficients, _, rank, _ = np.linalg.lstsq(basis, force, rcond=None)
    if rank < 4 or not np.ptp(x) > 0.0:
        raise SignalError(f"band {centre:.1f} Hz ({start:.2f}-{end:.2f} s): no seal motion to fit")
    residual = force - basis @ coefficients
    samples = t.size
    independent = max(min(samples, 2.0 * LOWPASS_HZ * (t[-1] - t[0])), 5.0)
    variance = float(residual @ residual) / max(samples - 4, 1) * samples / independent
    covariance = variance * np.linalg.inv(basis.T @ basis)
    k, c = float(coefficients[2]), float(coefficients[3])
    k_sigma, c_sigma = (math.sqrt(max(float(covariance[i, i]), 0.0)) for i in (2, 3))
    omega = 2.0 * math.pi * centre
    eta = c * omega / k
    eta_sigma = abs(eta) * math.hypot(c_sigma / c if c else 0.0, k_sigma / k if k else 0.0)
    return BandCharacterization(
        frequency_hz=centre,
        t_start=float(t[0]),
        t_end=float(t[-1]),
        seal_displacement_amplitude=0.5 * float(np.ptp(x - np.polyval(np.polyfit(t, x, 1), t))),
        k_eh=k,
        k_eh_sigma=k_sigma,
        c_eh=c,
        c_eh_sigma=c_sigma,
        k_eh_star=0.5 * k / static_stiffness,
        k_eh_star_sigma=0.5 * k_sigma / static_stiffness,
        eta_eh=eta,
        eta_eh_sigma=eta_sigma,
    )


def characterize_sweep(
    time: FloatArray, filtered: dict[str, FloatArray], rig: Rig, segment: Segment
) -> SweepCharacterization:
    """``k_eh``, ``c_eh``, ``k_eh*``, ``eta_eh`` per frequency band of one sweep segment.

    Args:
        time: sample times (s).
        filtered: ``p_b``, ``F_k``, ``x_c`` 30 Hz low-passed, on ``time``.
        rig: the rig file (block stiffness, piston area and mass, seal's static stiffness).
        segment: a ``sweep`` segment of :func:`segmentation.find_segments`.

    Raises:
        SignalError: a band without seal motion.
    """
    seal_displacement, seal_force = _seal_signals(time, filtered, rig)
    static = seal_properties(rig).static_stiffness
    bands = [_band(time, seal_displacement, seal_force, b, static) for b in band_windows(segment)]
    return SweepCharacterization(segment, bands)


@dataclass(frozen=True)
class RecordingCharacterization:
    """What ``brake-hil characterize`` finds in a recording."""

    steady: list[SegmentCharacterization]  # Table 3 per steady pulsing segment (as always)
    sweeps: list[SweepCharacterization]  # Table 3 against frequency per sweep
    segments: list[Segment]  # every segment found, of any kind


def characterize_recording(recording: Recording, rig: Rig) -> RecordingCharacterization:
    """Table 3 per steady segment and per frequency band of every sweep.

    Raises:
        RecordingError: a measured output is missing, or a channel does not vary.
        NoSteadyPulsingError: neither steady pulsing nor a sweep (the message names the
            segments found).
    """
    missing = [key for key, value in recording.measured().items() if value is None]
    if missing:
        raise RecordingError(
            f"{recording.path}: characterisation needs measured {', '.join(missing)}"
        )
    filtered = conditioned_channels(recording)
    time = recording.time
    segments = find_segments(time, filtered["p_i"], recording.sample_rate, rig.excitation_hz)
    steady = characterize(recording, rig) if any(s.steady for s in segments) else []
    sweeps = [characterize_sweep(time, filtered, rig, s) for s in segments if s.kind == "sweep"]
    if not steady and not sweeps:
        found = ", ".join(dict.fromkeys(s.kind for s in segments)) or "nothing"
        raise NoSteadyPulsingError(
            f"{recording.path}: characterisation needs steady pulsing at "
            f"{rig.excitation_hz:g} Hz or a sweep; the recording holds {found}"
        )
    return RecordingCharacterization(steady, sweeps, segments)
