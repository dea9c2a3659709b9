"""The one small interface of a generic form of the misfit, the data it sees, and its registry.

A form (:class:`ResidualForm`) predicts one measured channel from the calibrated baseline's
prediction with a few parameters; it joins the registry with :func:`register_form`, and
:data:`brake_hil.diagnosis.residual_forms.FORMS` lists the registered forms in the order they
joined.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar, TypeVar

import numpy as np

from brake_hil.types import FloatArray

__all__ = [
    "CHANNEL_UNITS",
    "FORM_ORDER",
    "MEGA",
    "ChannelSpans",
    "FormContext",
    "FormParameter",
    "LinearForm",
    "ResidualForm",
    "quantity",
    "register_form",
    "registered_forms",
    "warm_start",
]

CHANNEL_UNITS = {"p_b": "Pa", "F_k": "N", "x_c": "m"}
"""SI unit of each output channel."""
MEGA = 1e6
"""Pressures are fitted in MPa (and MPa s) and reported in Pa (and Pa s)."""


@dataclass(frozen=True)
class ChannelSpans:
    """One channel over a set of windows, normalised by the channel's scale (peak-to-peak).

    Lists hold one array per window; pressures are in MPa, volumes in MPa s.
    """

    predicted: list[FloatArray]  # y_hat / scale
    measured: list[FloatArray]  # y / scale
    level: list[float]  # window's mean p_i minus the reference, MPa
    volume: list[FloatArray]  # integral of p_b from the start minus the reference, MPa s
    time: list[FloatArray]  # s
    segment: list[int]
    sample_time: float  # s
    period_samples: int

    @property
    def target(self) -> FloatArray:
        """Measured samples, concatenated."""
        return np.concatenate(self.measured)

    @property
    def baseline(self) -> FloatArray:
        """Predicted samples, concatenated."""
        return np.concatenate(self.predicted)


def warm_start(signal: FloatArray, period_samples: int, periods: int) -> FloatArray:
    """``signal`` preceded by ``periods`` copies of its own first period (steady pulsing)."""
    head = signal[: min(period_samples, signal.size)]
    return np.concatenate([np.tile(head, periods), signal])


@dataclass(frozen=True)
class FormParameter:
    """One parameter of a fitted form, in SI units."""

    name: str
    value: float
    unit: str


class ResidualForm(ABC):
    """A generic physical form of a channel's misfit (one small interface for all six).

    A form predicts the measured channel from the baseline's prediction with a few
    parameters ``x`` in a search space (normalised channel, MPa, logarithms), and converts them
    to SI for the report.
    """

    name: ClassVar[str]
    phrase: ClassVar[str]  # what it is, in words: "a static nonlinear map"

    @abstractmethod
    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """``(name, unit)`` of each fitted parameter for a channel in ``unit``."""

    @abstractmethod
    def predict(self, x: FloatArray, data: ChannelSpans) -> FloatArray:
        """The channel (normalised) that baseline + form predicts, concatenated over windows."""

    @abstractmethod
    def starts(self) -> list[FloatArray]:
        """Start points in the search space; the fit starts from the best of them."""

    def bounds(self, size: int) -> tuple[FloatArray, FloatArray]:
        """Bounds of the search space (none by default)."""
        return np.full(size, -np.inf), np.full(size, np.inf)

    def jacobian(self, x: FloatArray, data: ChannelSpans) -> FloatArray | None:
        """The exact Jacobian where the form is linear in ``x`` (else finite differences)."""
        del x, data
        return None

    @abstractmethod
    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """The fitted parameters in SI units (``scale``: the channel's peak-to-peak)."""

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """A short physical reading of the fitted values (for the summary)."""
        del values, channel, context
        return ""

    def constants(self, context: FormContext) -> tuple[FormParameter, ...]:
        """The fixed references of the fit the form's parameters are relative to (SI)."""
        del context
        return ()


@dataclass(frozen=True)
class FormContext:
    """Fixed references of the fit, in SI."""

    reference_pressure: float  # Pa, mean of the training windows' mean p_i
    reference_volume: float  # Pa s, mean over the training samples of the p_b integral
    bore_pressure: float  # Pa, mean measured p_b over the training windows
    prediction_range: dict[str, tuple[float, float]]  # per channel, smallest/largest |y_hat|
    pressure_range: tuple[float, float]  # Pa, lowest and highest window mean p_i


class LinearForm(ResidualForm):
    """A form linear in its parameters: ``y = y_hat + F x``."""

    @abstractmethod
    def features(self, data: ChannelSpans) -> FloatArray:
        """The design matrix ``F`` (samples, parameters)."""

    def predict(self, x: FloatArray, data: ChannelSpans) -> FloatArray:
        """Baseline plus ``F x``."""
        return np.asarray(data.baseline + self.features(data) @ x, dtype=float)

    def jacobian(self, x: FloatArray, data: ChannelSpans) -> FloatArray | None:
        """``F``."""
        del x
        return self.features(data)

    def starts(self) -> list[FloatArray]:
        """Zero: the baseline."""
        return [np.zeros(len(self.parameter_units("")))]


FORM_ORDER = ("static_map", "backlash", "level_gain", "fluid_loss", "extra_lag", "resonance")
"""The order the library's forms are listed and fitted in (a tie in improvement keeps it)."""

_REGISTERED: dict[str, ResidualForm] = {}

FormClass = TypeVar("FormClass", bound=type[ResidualForm])


def register_form(cls: FormClass) -> FormClass:
    """Class decorator: an instance of ``cls`` joins the registry under ``cls.name``.

    Raises:
        ValueError: a form of that name is registered already.
    """
    if cls.name in _REGISTERED:
        raise ValueError(f"a residual form named {cls.name!r} is registered already")
    _REGISTERED[cls.name] = cls()
    return cls


def registered_forms() -> tuple[ResidualForm, ...]:
    """Every registered form: those of ``FORM_ORDER`` in its order, then others as they joined."""
    known = [_REGISTERED[name] for name in FORM_ORDER if name in _REGISTERED]
    return (*known, *(f for name, f in _REGISTERED.items() if name not in FORM_ORDER))


def quantity(value: float, unit: str) -> str:
    """A value with its unit at a readable scale (MPa, kN, um)."""
    if unit == "Pa":
        return f"{value / 1e6:.2f} MPa"
    if unit == "N":
        return f"{value / 1e3:.2f} kN"
    if unit == "m":
        return f"{value * 1e6:.1f} um"
    return f"{value:.3g} {unit}"
