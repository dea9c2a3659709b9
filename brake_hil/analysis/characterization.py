"""Characterisation of the seal from a recording: the seed's Table 3 (eqs. 1, 3-11).

For each steady 5 Hz segment the measured signals are low-passed (30 Hz, the seed's
conditioning); the seed then band-passes 4-6 Hz so that only the fundamental remains
(eq. 1). Here the fundamental is taken as its phasor, a least-squares fit over the segment's
whole cycles (:func:`signals.harmonic_phasor`): the narrow-band limit of that band-pass,
without the filter's transients at the segment's ends, which bias a loop integral by a few
per cent on a 4 s segment.

Conventions (physics.md asks to state them):

* Seal displacement ``x_s = x_p - x_c = F_k / k_k - x_c`` (seed); seal force from the piston
  balance, eq. 21e: ``F_s = A_ep p_b - F_k - M_p x_p''``. Both seals together.
* ``k_eh`` is the secant stiffness of the seal loop at the displacement turning points, i.e.
  the in-phase part of ``F_s`` over ``x_s`` at the fundamental, ``Re(F_s / X_s)``; for a
  Jenkins element it is about the peak force over the peak displacement, for the LTI model
  it is exactly ``k_eh``.
  The printed eq. 4, ``k_eh = F_fs / X_s`` with the *theoretical* ``F_fs``, is reported too
  as ``k_eh_eq4``.
* ``c_eh`` is the dissipated energy of the seal loop over ``pi w_e X_s^2`` (eq. 1 applied to
  the seal's own force and displacement, exact for the LTI model); at the fundamental the
  loop's area is ``pi Im(F_s conj(X_s))``, so ``c_eh = Im(F_s / X_s) / w_e``. The seed's
  literal eq. 1 on ``F_k`` against ``x_c`` is reported as ``c_eh_eq1``.
* ``c_fs`` (eq. 5, Jenkins loop ``dU_s = 4 F_fs (X_s - c_s)``), ``c_ss`` (eq. 6, scaled by the
  sticking share ``min(1, c_s / 2 X_s)``) and ``c_fb`` (eqs. 8-9) are per seal / per bore;
  the index ``xi = (2 c_fs + 2 c_ss + 2 c_fb) / c_eh`` (eq. 10), ``eta_eh = c_eh w_e / k_eh``
  (eq. 11), ``k_eh* = 0.5 k_eh / k_s``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
import math

import numpy as np

from brake_hil.analysis import signals
from brake_hil.analysis.comparison import check_varying, steady_windows
from brake_hil.analysis.recording import Recording
from brake_hil.errors import RecordingError, SignalError
from brake_hil.physics.parameters import (
    excitation_angular_frequency,
    piston_area,
    seal_properties,
)
from brake_hil.physics.rig import Rig
from brake_hil.types import FloatArray


@dataclass(frozen=True)
class SegmentCharacterization:
    """Table 3 quantities of one steady segment (SI unless marked)."""

    t_start: float  # s
    t_end: float  # s
    max_pressure: float  # Pa, highest master-cylinder pressure in the segment
    ptp_pressure: float  # Pa, bore pressure peak-to-peak
    seal_displacement_amplitude: float  # X_s, m
    seal_slips: bool  # 2 X_s > c_s (seed's slip check)
    k_eh: float  # N/m
    c_eh: float  # N s/m
    k_eh_eq4: float  # N/m, F_fs / X_s as printed
    c_eh_eq1: float  # N s/m, loop of F_k over x_c as printed
    k_eh_star: float  # 0.5 k_eh / k_s
    eta_eh: float  # c_eh w_e / k_eh
    c_fs: float  # N s/m, per seal
    c_ss: float  # N s/m, per seal
    c_fb: float  # N s/m, per bore
    two_c_fs_star: float  # 2 c_fs / c_eh
    two_c_ss_star: float  # 2 c_ss / c_eh
    two_c_fb_star: float  # 2 c_fb / c_eh
    xi: float  # (2 c_fs + 2 c_ss + 2 c_fb) / c_eh
    harmonic_energy_pct: dict[str, list[float]]  # Table 1, per signal

    def as_dict(self) -> dict[str, object]:
        """JSON-ready mapping (docs/interface.md's characterize segment)."""
        return asdict(self)


def loop_area(displacement: FloatArray, force: FloatArray) -> float:
    """Closed integral ``sum F dx`` over the given samples (J), trapezoidal.

    Positive for a loop traversed so that the force leads the displacement (dissipation).
    """
    dx = np.diff(displacement)
    mean_force = 0.5 * (force[1:] + force[:-1])
    return float(np.sum(mean_force * dx))


def jenkins_loop_area(friction_threshold: float, slip_threshold: float, amplitude: float) -> float:
    """Energy dissipated per cycle by a spring + Coulomb slider, ``4 F_fs (X - c_s)`` (J).

    Seed eq. 5; zero while the seal sticks (``X <= c_s``).
    """
    return 4.0 * friction_threshold * max(amplitude - slip_threshold, 0.0)


def characterize(recording: Recording, rig: Rig) -> list[SegmentCharacterization]:
    """Table 3 quantities for every steady segment of a recording."""
    missing = [key for key, value in recording.measured().items() if value is None]
    if missing:
        raise RecordingError(
            f"{recording.path}: characterisation needs measured {', '.join(missing)}"
        )
    check_varying(recording)
    rate = recording.sample_rate
    input_filtered = signals.lowpass(recording.master_cylinder_pressure, rate)
    segments = steady_windows(recording, input_filtered, rig)
    filtered = {
        key: signals.lowpass(np.asarray(value), rate)
        for key, value in recording.measured().items()
        if value is not None
    }
    filtered["p_i"] = input_filtered
    return [
        _characterize_segment(recording.time, filtered, rig, start, end) for start, end in segments
    ]


def _bore_friction_damping(
    rig: Rig, bore_pressure: FloatArray, caliper_displacement: FloatArray, amplitude: float
) -> float:
    """Equivalent viscous damping ``c_fb`` of the bore's friction over a segment (N s/m).

    The mean friction force (from the bore friction coefficient and area ratio, the piston
    area and the mean ``|p_b x_c|`` over the transducer distance), as the viscous damper
    that dissipates as much per cycle at the seal's displacement ``amplitude`` (m).
    """
    mean_friction = (
        4.0
        * rig.bore_friction_coefficient
        * rig.bore_area_ratio
        * piston_area(rig)
        * float(np.mean(np.abs(bore_pressure * caliper_displacement)))
        / rig.transducer_distance
    )
    return mean_friction / (excitation_angular_frequency(rig) * amplitude * 2.0 / math.pi)


def _characterize_segment(
    time: FloatArray,
    filtered: dict[str, FloatArray],
    rig: Rig,
    start: float,
    end: float,
) -> SegmentCharacterization:
    window = signals.segment_slice(time, start, end)
    t = time[window]
    rate = 1.0 / float(np.median(np.diff(time)))
    omega = excitation_angular_frequency(rig)
    seal = seal_properties(rig)
    area_ep = piston_area(rig)

    def phasor(key: str) -> complex:
        return signals.harmonic_phasor(filtered[key][window], t, rig.excitation_hz)

    bore_phasor, force_phasor, caliper_phasor = phasor("p_b"), phasor("F_k"), phasor("x_c")
    piston_phasor = force_phasor / rig.block_stiffness  # x_p = F_k / k_k
    seal_displacement = piston_phasor - caliper_phasor  # X_s
    seal_force = (  # eq. 21e: F_s = A_ep p_b - F_k - M_p x_p''
        area_ep * bore_phasor - force_phasor + rig.piston_mass * omega**2 * piston_phasor
    )
    if seal_displacement == 0 or caliper_phasor == 0:
        raise SignalError(
            f"segment {start:.2f}-{end:.2f} s: no seal or caliper motion at "
            f"{rig.excitation_hz:g} Hz to characterise"
        )
    seal_impedance = seal_force / seal_displacement  # k_eh + j w_e c_eh
    amplitude = abs(seal_displacement)
    k_eh = seal_impedance.real
    c_eh = seal_impedance.imag / omega
    if k_eh == 0 or c_eh == 0:
        raise SignalError(
            f"segment {start:.2f}-{end:.2f} s: the seal's stiffness or damping is exactly 0"
        )
    c_eh_eq1 = abs((force_phasor * caliper_phasor.conjugate()).imag) / (
        omega * abs(caliper_phasor) ** 2
    )

    c_fs = jenkins_loop_area(seal.friction_threshold, seal.slip_threshold, amplitude) / (
        math.pi * omega * amplitude**2
    )
    sticking_share = min(1.0, seal.slip_threshold / (2.0 * amplitude))
    c_ss = seal.static_stiffness * rig.seal.loss_factor / omega * sticking_share
    bore_pressure = filtered["p_b"][window]
    c_fb = _bore_friction_damping(rig, bore_pressure, filtered["x_c"][window], amplitude)
    harmonics = {
        key: [
            float(v)
            for v in signals.harmonic_energy_shares(
                filtered[key][window], rate, fundamental_hz=rig.excitation_hz
            )
        ]
        for key in ("p_i", "p_b", "F_k", "x_c")
    }
    return SegmentCharacterization(
        t_start=float(start),
        t_end=float(end),
        max_pressure=float(np.max(filtered["p_i"][window])),
        ptp_pressure=float(np.ptp(bore_pressure)),
        seal_displacement_amplitude=amplitude,
        seal_slips=2.0 * amplitude > seal.slip_threshold,
        k_eh=k_eh,
        c_eh=c_eh,
        k_eh_eq4=seal.friction_threshold / amplitude,
        c_eh_eq1=c_eh_eq1,
        k_eh_star=0.5 * k_eh / seal.static_stiffness,
        eta_eh=c_eh * omega / k_eh,
        c_fs=c_fs,
        c_ss=c_ss,
        c_fb=c_fb,
        two_c_fs_star=2.0 * c_fs / c_eh,
        two_c_ss_star=2.0 * c_ss / c_eh,
        two_c_fb_star=2.0 * c_fb / c_eh,
        xi=(2.0 * c_fs + 2.0 * c_ss + 2.0 * c_fb) / c_eh,
        harmonic_energy_pct=harmonics,
    )
