"""The engine's own mechanisms that more than a single law needs.

A switching friction element between piston and caliper, a per-channel delay of the
outputs, one output read through a second-order mode, and every output led alike (an input
acquired late through its filter).
"""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np
import scipy.signal

from brake_hil.diagnosis.engine.plant import RELATIVE_FORCE, Coupling
from brake_hil.diagnosis.engine.terms import Entry, State, Step, Term
from brake_hil.types import FloatArray, IndexArray

__all__ = ["ChannelDelay", "ChannelReading", "FrictionElement", "LeadingOutputs", "tustin_mode"]

STUCK, SLIPPING = 0, 1


def _sum(a: FloatArray | None, b: FloatArray | None) -> FloatArray | None:
    if a is None or b is None:
        return b if a is None else a
    return a + b


@dataclass(frozen=True, eq=False)
class FrictionElement(Term):
    """A Jenkins element between piston and caliper, in parallel with k_eh and c_eh.

    An ideal spring ``k_j`` in series with a Coulomb slider. Its slip threshold is a constant
    per direction (apply: while ``x_p - x_c`` grows; release: while it shrinks) plus
    ``mu p_b |x_c|``. The element switches between two exactly discretised linear systems,
    *stuck* (spring present, offset held) and *slipping* (spring absent, the friction force
    an input held over the step), so a stiff stuck spring is integrated exactly and slip adds
    no artificial damping.
    """

    spring: FloatArray  # N/m, k_j
    apply_threshold: FloatArray  # N, slip force while x_p - x_c grows
    release_threshold: FloatArray  # N, slip force while it shrinks
    bore_friction: FloatArray | None = None  # N/(Pa m), threshold per p_b |x_c|
    contact: bool = False  # the spring is only a stiff contact: another element's replaces it

    modes = 2  # STUCK, SLIPPING

    def couple(self, coupling: Coupling, row: int, entry: Entry) -> None:
        """The spring acts while the slider sticks."""
        if entry.mode == STUCK:
            coupling.extra_stiffness += float(self.spring[row])

    def start(self, state: State) -> Step:
        """Every slider stuck and relaxed."""
        return _Slider(self, len(state.params))

    def merge(self, other: FrictionElement) -> FrictionElement:
        """One slider: thresholds add; a contact's spring gives way to a seal's."""
        spring = other.spring if self.contact and not other.contact else self.spring
        return FrictionElement(
            spring,
            self.apply_threshold + other.apply_threshold,
            self.release_threshold + other.release_threshold,
            _sum(self.bore_friction, other.bore_friction),
            self.contact and other.contact,
        )


class _Slider(Step):
    """The slider's state: stuck or slipping, its offset and its slip direction."""

    def __init__(self, element: FrictionElement, batch: int) -> None:
        self.element = element
        self.state: IndexArray = np.zeros(batch, dtype=np.intp)
        self.offset = np.zeros(batch)  # x_p - x_c at which the stuck spring is relaxed
        self.direction = np.zeros(batch)  # +1 slipping while applying, -1 while releasing
        self.symmetric = bool(np.array_equal(element.apply_threshold, element.release_threshold))

    def mode(self) -> IndexArray:
        """STUCK or SLIPPING per set."""
        return self.state

    def _bore_threshold(self, state: State) -> FloatArray | float:
        if self.element.bore_friction is None:
            return 0.0
        return np.asarray(
            self.element.bore_friction * np.abs(state.value("p_b") * state.value("x_c"))
        )

    def _held(self, state: State) -> FloatArray:
        """Slip force per set in its current slip direction (N)."""
        e = self.element
        own = (
            e.apply_threshold
            if self.symmetric
            else np.where(self.direction > 0, e.apply_threshold, e.release_threshold)
        )
        return np.asarray(own + self._bore_threshold(state))

    def inputs(self, state: State, explicit: FloatArray) -> None:
        """The stuck spring's offset force, or the friction force while slipping."""
        e = self.element
        explicit[:, RELATIVE_FORCE] += np.where(
            self.state == STUCK, e.spring * self.offset, -self.direction * self._held(state)
        )

    def update(self, state: State) -> None:
        """Stick-slip transitions after a step (return mapping).

        Most steps change nothing; only the sets that switch are written.
        """
        e, spring = self.element, self.element.spring
        seal = state.seal()
        extra = self._bore_threshold(state)
        stuck = self.state == STUCK
        trial = spring * (seal - self.offset)
        start_apply = stuck & (trial > e.apply_threshold + extra)
        start_release = stuck & (trial < -(e.release_threshold + extra))
        stick = ~stuck & (self.direction * state.seal_velocity() <= 0.0)
        if stick.any():
            held = self._held(state)
            self.offset[stick] = seal[stick] - self.direction[stick] * held[stick] / spring[stick]
            self.state[stick] = STUCK
        if start_apply.any():
            self.direction[start_apply] = 1.0
            self.state[start_apply] = SLIPPING
        if start_release.any():
            self.direction[start_release] = -1.0
            self.state[start_release] = SLIPPING


@dataclass(frozen=True, eq=False)
class ChannelDelay(Term):
    """Each output channel acquired late by its own delay (linear interpolation)."""

    delays: FloatArray  # (B, 3) s, per channel p_b, F_k, x_c; negative: p_i acquired late

    linear = True

    def transform(self, outputs: FloatArray, sample_time: float) -> FloatArray:
        """Shift each channel by its delay."""
        time = np.arange(outputs.shape[-1]) * sample_time
        for b in range(outputs.shape[0]):
            for channel in range(3):
                delay = float(self.delays[b, channel])
                if delay != 0.0:
                    outputs[b, channel] = np.interp(time - delay, time, outputs[b, channel])
        return outputs


@dataclass(frozen=True, eq=False)
class ChannelReading(Term):
    """One output channel read through ``w^2 / (s^2 + 2 zeta w s + w^2)`` (unit static gain).

    A transducer behind a resonant tapping line or mount. Tustin-discretised with the
    frequency prewarped, started at rest at the run's first value.
    """

    channel: int  # 0 p_b, 1 F_k, 2 x_c
    frequency: FloatArray  # (B,) natural frequency f_n, Hz
    damping_ratio: FloatArray  # (B,) zeta, -

    linear = True

    def transform(self, outputs: FloatArray, sample_time: float) -> FloatArray:
        """Filter the channel of every set."""
        for b in range(outputs.shape[0]):
            numerator, _, denominator = tustin_mode(
                float(self.frequency[b]), float(self.damping_ratio[b]), sample_time
            )
            signal = outputs[b, self.channel]
            start = scipy.signal.lfilter_zi(numerator, denominator) * signal[0]
            outputs[b, self.channel] = scipy.signal.lfilter(
                numerator, denominator, signal, zi=start
            )[0]
        return outputs


def tustin_mode(
    frequency: float, damping_ratio: float, sample_time: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """A second-order mode ``s^2 + 2 zeta w s + w^2``, Tustin-discretised, ``w`` prewarped.

    Returns the numerators of its read-through ``w^2 / (...)`` and of its relative motion
    ``s^2 / (...)``, and the common denominator (``z^-1`` coefficients). The frequency (Hz)
    is held under 0.45 of the sample rate.
    """
    k = 2.0 / sample_time  # Tustin: s = k (1 - 1/z) / (1 + 1/z)
    frequency = min(frequency, 0.45 / sample_time)
    omega = k * math.tan(math.pi * frequency * sample_time)  # prewarped, rad/s
    damping = 2.0 * damping_ratio * omega * k
    a0 = k * k + damping + omega * omega
    read_through = np.array([1.0, 2.0, 1.0]) * omega * omega / a0
    relative = np.array([1.0, -2.0, 1.0]) * k * k / a0
    denominator = np.array(
        [1.0, 2.0 * (omega * omega - k * k) / a0, (k * k - damping + omega * omega) / a0]
    )
    return read_through, relative, denominator


@dataclass(frozen=True, eq=False)
class LeadingOutputs(Term):
    """Every output advanced by ``advance`` and led by ``lead``: ``y(t) = u(t + a) + T u'(t + a)``.

    What the model predicts from an input ``p_i`` acquired ``a`` late through a first-order
    filter of time constant ``T`` (the filter inverted to first order). The last ``a`` of a
    run holds its final value.
    """

    advance: FloatArray  # (B,) a, s
    lead: FloatArray  # (B,) T, s

    linear = True

    def transform(self, outputs: FloatArray, sample_time: float) -> FloatArray:
        """Advance and lead every channel of every set."""
        time = np.arange(outputs.shape[-1]) * sample_time
        for b in range(outputs.shape[0]):
            for channel in range(outputs.shape[1]):
                early = np.interp(time + float(self.advance[b]), time, outputs[b, channel])
                outputs[b, channel] = early + float(self.lead[b]) * np.gradient(early, sample_time)
        return outputs


@dataclass(frozen=True, eq=False)
class WanderingZeros(Term):
    """Each output's zero moving at a steady rate: ``y(t) + r (t - t_0)``.

    What a transducer whose zero walks during the recording reads; ``t`` is recording time,
    ``t_0`` the time at which the zeros are the calibrated model's.
    """

    rates: FloatArray  # (B, 3) per channel: p_b Pa/s, F_k N/s, x_c m/s
    reference: FloatArray  # (B,) t_0, s

    linear = True

    def transform_at(
        self, outputs: FloatArray, sample_time: float, start_time: FloatArray
    ) -> FloatArray:
        """Add each set's moving zeros."""
        time = np.arange(outputs.shape[-1]) * sample_time
        since = np.asarray(start_time, dtype=float)[:, None] + time - self.reference[:, None]
        return np.asarray(outputs + self.rates[:, :, None] * since[:, None, :])
