"""The truth laws (the host's ports) of the five effects outside the library (SI).

What :mod:`brake_hil.virtual_rig.family_b.outside` binds to a rig: a leaky line, a bypassed
valve, a load cell's play, a resonant pressure tapping and a transducer zero that shifts.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
import math

import numpy as np
from scipy.signal import lfilter, lsim

from brake_hil.types import FloatArray
from brake_hil.virtual_rig.laws import LineFlow, LinePorts, Signal, TruthLaw

__all__ = ["BypassedValve", "LeakyLine", "PeakZeroShift", "PlayHysteresis", "TapResonance"]


@dataclass(frozen=True)
class LeakyLine(TruthLaw):
    """The host's lumped line (eq. 21c), less a leak out of the bore chamber (SI).

    The host's line port. Leak flow ``Q_L = G_L (R_t0 / R_t) p_b (1 + p_b / p_d)^3``: laminar
    through a gap ``h = h_0 (1 + p_b / p_d)`` (``Q ~ h^3 / mu``), the viscosity read from the
    hose's present resistance ``R_t`` against its nominal ``R_t0``.
    """

    conductance: float  # G_L, m^3/(Pa s)
    dilation_pressure: float  # p_d, Pa
    nominal_hose_resistance: float  # R_t0, Pa s/m^3

    def leak(self, bore_pressure: Signal, hose_resistance: Signal) -> Signal:
        """Leak flow (m^3/s) out of the bore at ``bore_pressure`` (Pa)."""
        opening = 1.0 + bore_pressure / self.dilation_pressure
        fluidity = self.nominal_hose_resistance / hose_resistance
        return self.conductance * fluidity * bore_pressure * opening * opening * opening

    def line_flow(self, line: LinePorts, states: Sequence[Signal]) -> LineFlow:
        """Eq. 21c's lumped line; the bore receives ``Q_h - Q_L``."""
        rate, own, into_bore, added = super().line_flow(line, states)
        leak = self.leak(line.bore_pressure, line.hose_resistance)
        return rate, own, into_bore - leak, added


@dataclass(frozen=True)
class BypassedValve(TruthLaw):
    """The needle valve with a check valve across it that opens on release (SI).

    The host's valve port. With the needle's linearised resistance ``R_v`` (times the drift's
    valve factor) and a check of conductance ``G_b = r_b / R_v`` cracking at ``p_c``, the flow
    through needle and check at a drop ``dp`` is ``dp / R_v`` while the check is shut and
    ``dp / R_v + G_b (dp + p_c)`` once ``dp < -p_c`` (release, ``Q_h < 0``). Inverted:
    ``dp = R_v Q + (R_v - R_r) ramp(q_c - Q)``, ``q_c = -p_c / R_v``, ``R_r = R_v / (1 + r_b)``,
    the ramp smoothed by a hyperbola over ``smoothing`` Pa.
    """

    bypass_ratio: float  # r_b = G_b R_v, -
    cracking_pressure: float  # p_c, Pa
    smoothing: float  # Pa

    def valve_drop(
        self,
        flow: Signal,
        linear_resistance: float,
        viscosity_factor: Signal,
        linear_factor: Signal,
    ) -> Signal:
        """The drop (Pa) over needle and check at ``flow`` (m^3/s, positive to the bore)."""
        del viscosity_factor
        resistance = linear_resistance * linear_factor
        cracking_flow = -self.cracking_pressure / resistance
        corner = self.smoothing / resistance
        excess = cracking_flow - flow
        ramp = 0.5 * (excess + np.sqrt(excess * excess + corner * corner))
        relief = resistance * self.bypass_ratio / (1.0 + self.bypass_ratio)
        return resistance * flow + relief * ramp


@dataclass(frozen=True)
class PlayHysteresis(TruthLaw):
    """A channel read through a Prandtl-Ishlinskii hysteresis (SI).

    The host's acquisition port. ``v + sum_i w_i (P_ri[v] - v)``: ``P_r`` the play (backlash)
    operator of radius ``r`` (``y_k = min(v_k + r, max(v_k - r, y_k-1))``, starting at the first
    reading), radii ``r_i = i r / n`` (``i = 1 .. n``), equal weights ``w`` with
    ``w sum_i r_i = error``: the largest reading error, reached once every play is taken up.
    """

    channel: str  # F_k
    error: float  # N, largest hysteresis error
    radius: float  # N, largest play radius
    operators: int  # n

    def apply(self, values: FloatArray) -> FloatArray:
        """``values`` through the hysteresis, in time order."""
        radii = [self.radius * (i + 1) / self.operators for i in range(self.operators)]
        weight = self.error / sum(radii)
        samples = np.asarray(values, dtype=float).tolist()
        first = samples[0]
        outputs = [first] * self.operators
        result = np.empty(len(samples))
        for index, value in enumerate(samples):
            total = 0.0
            for k, radius in enumerate(radii):
                played = min(value + radius, max(value - radius, outputs[k]))
                outputs[k] = played
                total += played - value
            result[index] = value + weight * total
        return result

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        """The hysteretic channel through :meth:`apply`; the others unchanged."""
        del time
        return self.apply(values) if channel == self.channel else values


@dataclass(frozen=True)
class TapResonance(TruthLaw):
    """A channel read through ``w^2 / (s^2 + 2 zeta w s + w^2)`` (SI).

    The host's acquisition port. Integrated exactly with the input linear between samples
    (``scipy.signal.lsim``), starting at rest at the first reading.
    """

    channel: str  # p_b
    natural_frequency: float  # f_n, 1/s
    damping_ratio: float  # zeta, -

    def apply(self, time: FloatArray, values: FloatArray) -> FloatArray:
        """``values`` (sampled at ``time``, s) through the tapping line."""
        omega = 2.0 * math.pi * self.natural_frequency
        state = np.array([[0.0, 1.0], [-omega * omega, -2.0 * self.damping_ratio * omega]])
        system = (state, np.array([[0.0], [omega * omega]]), np.array([[1.0, 0.0]]), 0.0)
        start = np.array([float(values[0]), 0.0])
        _, reading, _ = lsim(system, values, time - time[0], X0=start)
        return np.asarray(reading, dtype=float)

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        """The tapped channel through :meth:`apply`; the others unchanged."""
        return self.apply(time, values) if channel == self.channel else values


@dataclass(frozen=True)
class PeakZeroShift(TruthLaw):
    """A channel read with an offset ``z``: ``tau_z z' = s_z max_(t' <= t) v(t') - z`` (SI).

    The host's acquisition port; ``z`` starts at ``s_z v(0)`` and is integrated exactly over
    each sample interval with the running peak held.
    """

    channel: str  # p_b
    shift: float  # s_z, -
    creep_time: float  # tau_z, s

    def apply(self, time: FloatArray, values: FloatArray) -> FloatArray:
        """``values`` (sampled at ``time``, s) with the zero shift added."""
        target = self.shift * np.maximum.accumulate(np.asarray(values, dtype=float))
        step = float(np.median(np.diff(time))) if time.size > 1 else 1.0
        decay = math.exp(-step / self.creep_time)
        offset, _ = lfilter([1.0 - decay], [1.0, -decay], target, zi=[decay * target[0]])
        return np.asarray(values + offset, dtype=float)

    def acquisition(self, channel: str, time: FloatArray, values: FloatArray) -> FloatArray:
        """The shifted channel through :meth:`apply`; the others unchanged."""
        return self.apply(time, values) if channel == self.channel else values
