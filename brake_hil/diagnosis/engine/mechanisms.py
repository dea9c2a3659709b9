"""The engine's own mechanisms that more than a single law needs.

A switching friction element between piston and caliper, and a per-channel delay of the
outputs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from brake_hil.diagnosis.engine.plant import RELATIVE_FORCE, Coupling
from brake_hil.diagnosis.engine.terms import Entry, State, Step, Term
from brake_hil.types import FloatArray, IndexArray

__all__ = ["ChannelDelay", "FrictionElement"]

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

    def mode(self) -> IndexArray:
        """STUCK or SLIPPING per set."""
        return self.state

    def _bore_threshold(self, state: State) -> FloatArray | float:
        if self.element.bore_friction is None:
            return 0.0
        return np.asarray(
            self.element.bore_friction * np.abs(state.value("p_b") * state.value("x_c"))
        )

    def inputs(self, state: State, explicit: FloatArray) -> None:
        """The stuck spring's offset force, or the friction force while slipping."""
        e = self.element
        slip_force = np.where(
            self.direction > 0, e.apply_threshold, e.release_threshold
        ) + self._bore_threshold(state)
        explicit[:, RELATIVE_FORCE] += np.where(
            self.state == STUCK, e.spring * self.offset, -self.direction * slip_force
        )

    def update(self, state: State) -> None:
        """Stick-slip transitions after a step (return mapping)."""
        e, spring = self.element, self.element.spring
        seal = state.seal()
        velocity = state.seal_velocity()
        extra = self._bore_threshold(state)
        mode, direction = self.state, self.direction
        trial = spring * (seal - self.offset)
        start_apply = (mode == STUCK) & (trial > e.apply_threshold + extra)
        start_release = (mode == STUCK) & (trial < -(e.release_threshold + extra))
        stick = (mode == SLIPPING) & (direction * velocity <= 0.0)
        held = np.where(direction > 0, e.apply_threshold, e.release_threshold) + extra
        self.offset = np.where(stick, seal - direction * held / spring, self.offset)
        self.direction = np.where(start_apply, 1.0, np.where(start_release, -1.0, direction))
        self.state = np.where(start_apply | start_release, SLIPPING, np.where(stick, STUCK, mode))


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
