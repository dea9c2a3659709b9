"""The protocol through which the engine takes effects: terms added to the LTI model.

A candidate contributes :class:`Term` objects (arrays of length ``B``, one value per
parameter set); the engine calls their hooks and knows nothing else of them:

* :meth:`Term.couple` changes the linear plant (a :class:`~.plant.Coupling`: stiffness,
  damping, line resistance, bore compliance, a hose node) at one schedule entry. A term
  scheduled on the bore pressure or on time, or switching between ``modes`` discrete states,
  gets its transition matrices tabulated over those axes and each step takes its entry.
* :meth:`Term.start` returns the term's :class:`Step` for one run: its state, the explicit
  inputs it holds over a step (:data:`~.plant.RELATIVE_FORCE`, :data:`~.plant.CALIPER_FORCE`,
  :data:`~.plant.LINE_DROP`), its mode before a step and its update after one.
* :meth:`Term.transform` changes the outputs of a whole run (a per-channel delay).

Two candidates that act through the same mechanism contribute terms of one kind, which
:meth:`Term.merge` joins (a seal's Jenkins element and the bore's friction share one slider).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Protocol, TypeVar

import numpy as np

from brake_hil.diagnosis.engine.plant import Coupling
from brake_hil.errors import EffectError
from brake_hil.physics.parameters import ModelParameters
from brake_hil.types import FloatArray, IndexArray

__all__ = ["Entry", "MidStep", "ModelSpec", "State", "Step", "Term"]

T = TypeVar("T", bound="Term")


@dataclass(frozen=True)
class Entry:
    """One entry of the schedule a term's change of the linear plant is tabulated over."""

    pressure: float  # Pa, bore pressure of the grid level (0 unless a term is scheduled on it)
    time: float  # s, recording time in the middle of the time block
    mode: int  # the term's own discrete state, 0 .. modes - 1 (0 at the start)


class State(Protocol):
    """What a term's step sees of the integrator (arrays over the batch, SI units)."""

    @property
    def params(self) -> tuple[ModelParameters, ...]:
        """The LTI coefficients of every set."""
        ...

    @property
    def sample_time(self) -> float:
        """Step (s)."""
        ...

    def value(self, name: str) -> FloatArray:
        """One state of the plant: ``Q_h``, ``p_b``, ``x_p``, ``v_p``, ``x_c``, ``v_c``.

        With a hose node also ``Q_p``, ``p_h``.
        """
        ...

    def seal(self) -> FloatArray:
        """Seal deflection ``x_p - x_c`` (m)."""
        ...

    def seal_velocity(self) -> FloatArray:
        """``v_p - v_c`` (m/s)."""
        ...

    def line_flow(self) -> FloatArray:
        """Flow through the valve (m^3/s): ``Q_p`` with a hose node, else ``Q_h``."""
        ...


class Step:
    """A term's part of every step of one run; holds its state between steps."""

    def mode(self) -> IndexArray:
        """The term's discrete state per set before the next step (moded terms only)."""
        raise NotImplementedError

    def inputs(self, state: State, explicit: FloatArray) -> None:
        """Add this term's explicit inputs (B, INPUTS) held over the next step."""

    def update(self, state: State) -> None:
        """Update this term's state after a step."""


class MidStep:
    """A state's value extrapolated to the middle of the coming step (second order).

    An explicit input is held over the step; computed from the state at the step's start it
    lags the state by half a step, which a strong nonlinear term turns into a phase error
    (a turbulent valve taking most of the line's drop, held so, left 13-42 times the noise's
    share that a sensor delay or a hose then took up; at the mid-step flow 4-11 times, and
    neither helped: four orifices of both families).
    ``y_k + minmod(y_k - y_(k-1), y_(k-1) - y_(k-2)) / 2``: the slope limiter (minmod: the
    smaller of two slopes of one sign, else none) keeps the explicit input from feeding an
    oscillation of the step's own period (plain extrapolation went unstable at a drop 20
    times the orifice candidate's largest, where the held input was still stable at 50 times,
    and so is this), and at a turning point it holds the start's value.
    """

    def __init__(self) -> None:
        self._previous: FloatArray | None = None
        self._slope: FloatArray | None = None

    def __call__(self, now: FloatArray) -> FloatArray:
        """The value at the middle of the step starting at ``now`` (same units)."""
        current = np.array(now, dtype=float)
        previous, self._previous = self._previous, current
        if previous is None:
            return current
        slope, last = current - previous, self._slope
        self._slope = slope
        if last is None:
            return current
        limited = np.where(
            slope * last > 0.0, np.sign(slope) * np.minimum(abs(slope), abs(last)), 0.0
        )
        return np.asarray(current + 0.5 * limited)


class Term:
    """One piece of physics added to the LTI model, for a batch of parameter sets.

    A term overrides the hooks it needs; the class attributes tell the engine how to
    schedule it.
    """

    linear: ClassVar[bool] = False
    """The term only changes the linear plant, alike at every entry (the modal path applies)."""
    pressure_scheduled: ClassVar[bool] = False
    """Its change of the linear plant depends on the bore pressure."""
    time_scheduled: ClassVar[bool] = False
    """Its change of the linear plant depends on the recording time."""
    modes: ClassVar[int] = 1
    """Discrete states it switches the linear plant between (its Step reports the mode)."""

    def couple(self, coupling: Coupling, row: int, entry: Entry) -> None:
        """Change the linear plant of set ``row`` at ``entry``."""

    def start(self, state: State) -> Step | None:
        """This term's step for a run starting at equilibrium ``state`` (None: none)."""
        return None

    def transform(self, outputs: FloatArray, sample_time: float) -> FloatArray:
        """Change the outputs ``(B, 3, N)`` (p_b Pa, F_k N, x_c m) of a whole run."""
        return outputs

    def transform_at(
        self, outputs: FloatArray, sample_time: float, start_time: FloatArray
    ) -> FloatArray:
        """:meth:`transform` of a run whose sets start at recording times ``start_time`` (B,) s.

        The engine calls this one; a term whose change of the outputs depends on the
        recording time overrides it, the others :meth:`transform`.
        """
        return self.transform(outputs, sample_time)

    def merge(self: T, other: T) -> T:
        """This term joined with ``other`` of the same kind (two effects, one mechanism).

        Raises:
            EffectError: the kind acts once per model.
        """
        raise EffectError(f"two {type(self).__name__} terms in one model")


@dataclass(frozen=True)
class ModelSpec:
    """One candidate model for a batch of ``B`` parameter sets.

    The calibrated LTI coefficients of each set and the terms added to them (none: the LTI
    model).
    """

    params: tuple[ModelParameters, ...]
    terms: tuple[Term, ...] = ()

    @property
    def batch(self) -> int:
        """Number of parameter sets."""
        return len(self.params)

    @property
    def is_linear(self) -> bool:
        """True when every term is linear (the fast modal path applies)."""
        return all(term.linear for term in self.terms)

    def term(self, kind: type[T]) -> T | None:
        """The term of ``kind``, if there is one."""
        return next((t for t in self.terms if isinstance(t, kind)), None)
