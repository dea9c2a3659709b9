"""What an ``unexplained`` misfit looks like, and which generic physical form explains it best.

When no candidate of the library explains the calibrated LTI baseline's misfit, the verdict is
``unexplained``; this module says what that misfit is in physical terms (interface.md:
``verdict.unexplained_form``). It takes the dataset and the baseline's predictions of every
output channel over the training and held-out windows, and

1. describes the misfit (:class:`ChannelMisfit`, one per channel): its share of the baseline's
   held-out error (normalised by ``Dataset.scale()``); static or rate-dependent (how much of it
   a static map ``y = f(y_hat)`` explains, and how much more terms in the rate ``dy_hat/dt``
   add); symmetric or not between apply (rising) and release (falling) halves; whether it
   changes with the pressure level (the three segments compared) and which way: it "grows
   with pressure" when the measured channel grows relative to the prediction as the level
   rises (the calibration centres such a misfit, so its size at each level cannot say it);
   whether it drifts in time;
2. fits six generic forms (``FORMS``) to each channel's residual on the training windows with
   :func:`scipy.optimize.least_squares` and scores them on the held-out windows
   (improvement = the baseline's held-out mean squared error over that of baseline + form, per
   channel and over all channels, the measure ``Fit.held_out_cost`` takes);
3. returns a :class:`ResidualDescription`: the shares, the flags, the forms ranked by held-out
   improvement with their parameters and units, the best form, a one-sentence ``summary`` and
   :meth:`ResidualDescription.as_dict` for ``diagnosis.json``.

The forms, each of one channel (``y_hat`` predicted, ``y`` measured, SI units of the channel):

``static_map``
    ``y = y_hat + c0 + c1 y_hat + c2 y_hat^2 + c3 y_hat^3``: a transducer or a stiffness whose
    gain changes with its reading (cubic static nonlinearity).
``backlash``
    ``y = P_w[y_hat] + c0``, ``P_w`` the play (backlash) operator of width ``w``: the output
    stays put for ``w`` after each reversal (hysteresis, dead band on reversal; Krasnosel'skii
    and Pokrovskii, *Systems with Hysteresis*, 1989).
``level_gain``
    ``y = (1 + g0 + g1 (p_seg - p_ref)) y_hat + c0``: a gain that changes with the segment's
    mean master-cylinder pressure ``p_seg`` (amplitude-dependent stiffness or gain).
``fluid_loss``
    ``y = y_hat + c0 + k (V(t) - V_ref)``, ``V(t)`` the integral of the measured bore pressure
    from the recording's start (Pa s): fluid lost through a laminar leak ``Q = p_b / R_l``
    makes the channel drift in proportion to the volume lost.
``extra_lag``
    ``y = L_tau[y_hat] + c0``, ``L_tau`` a first-order lag ``tau y' + y = y_hat``.
``resonance``
    ``y = y_hat + g z + c0`` with ``z'' + 2 zeta omega z' + omega^2 z = -y_hat''``, a
    second-order mode (20-150 Hz) driven by the predicted signal's acceleration (base
    excitation; ``g = 1`` is the mode's full transmissibility).

Every form carries an offset ``c0``, so that no form wins by absorbing a constant misfit
alone. Stateful forms (play, lag, mode) are started from the window's own first period
repeated (the steady pulsing is periodic), so their start-up transient is outside the window.

Entry points: :func:`describe_residual` with the predictions of :func:`baseline_predictions`
(about 0.3-0.6 s for an 18 s recording: eighteen small fits). From
:func:`brake_hil.diagnosis.diagnose.diagnose`::

    predictions = baseline_predictions(baseline_model, baseline.theta)
    description = describe_residual(dataset, predictions, noise_cost=dataset.noise_cost())
    description.summary, description.as_dict(), description.verdict_entry()
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
import math
from typing import ClassVar, Protocol

import numpy as np
import scipy.optimize
import scipy.signal

from brake_hil.diagnosis.dataset import Dataset, Window
from brake_hil.diagnosis.engine.mechanisms import tustin_mode
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray, IndexArray

__all__ = [
    "CHANNEL_UNITS",
    "FORMS",
    "ChannelMisfit",
    "ChannelSpans",
    "FormContext",
    "FormFit",
    "FormParameter",
    "ResidualDescription",
    "ResidualForm",
    "WindowSimulator",
    "baseline_predictions",
    "describe_residual",
]

CHANNEL_UNITS = {"p_b": "Pa", "F_k": "N", "x_c": "m"}
"""SI unit of each output channel."""
STANDS_OUT_RATIO = 1.5
"""A form stands out when it cuts the held-out error at least this many times (the
diagnosis's ``CLEAR_ACCEPT_RATIO``) ..."""
NOISE_EXCESS = 4.0
"""... and the baseline's held-out error is at least this many times the noise's share."""
STATIC_SHARE = 0.5
"""The misfit is static when a static cubic map of the prediction explains this share of it."""
RATE_SHARE = 0.3
"""It is rate-dependent when terms in ``dy_hat/dt`` explain this share more than the map."""
ASYMMETRY_LIMIT = 0.15
"""Apply and release differ when ``(E_apply - E_release) / (E_apply + E_release)`` exceeds
this in magnitude (``E`` the mean squared misfit at the same levels of the prediction)."""
LEVEL_VARIATION = 0.5
"""The misfit changes with the pressure level when the segments' mean misfit or gain error
(relative to each segment's swing) changes across them by this share of the misfit's typical
relative RMS, monotonically with the level."""
DRIFT_SHARE = 0.5
"""It drifts when a linear trend in time explains this share of the within-segment variance of
its cycle means ..."""
DRIFT_SIZE = 0.2
"""... and that trend's change over a segment is this share of the misfit's RMS."""
MEGA = 1e6
"""Pressures are fitted in MPa (and MPa s) and reported in Pa (and Pa s)."""


class WindowSimulator(Protocol):
    """What :func:`baseline_predictions` needs of a model (``fitting.Model`` is one)."""

    @property
    def dataset(self) -> Dataset:
        """The dataset the model simulates."""
        ...

    def simulate(
        self, window: Window, theta: FloatArray, span: float | None = None
    ) -> tuple[FloatArray, IndexArray]:
        """Outputs (B, 3, n) over a window and its sample indices."""
        ...


def baseline_predictions(model: WindowSimulator, theta: FloatArray) -> dict[Window, FloatArray]:
    """The model's outputs (3, n) (p_b Pa, F_k N, x_c m) over every training and held-out window.

    Args:
        model: the calibrated baseline (``Model(calibration, [], dataset)``).
        theta: its fitted parameters (``Fit.theta``).

    Returns:
        For each window of ``dataset.train + dataset.held_out``, the predictions at the
        samples ``dataset.mask((window,))`` selects.
    """
    windows = (*model.dataset.train, *model.dataset.held_out)
    return {w: np.asarray(model.simulate(w, theta[None, :])[0][0], dtype=float) for w in windows}


# --- the data, per channel ------------------------------------------------------------------


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


def _warm_start(signal: FloatArray, period_samples: int, periods: int) -> FloatArray:
    """``signal`` preceded by ``periods`` copies of its own first period (steady pulsing)."""
    head = signal[: min(period_samples, signal.size)]
    return np.concatenate([np.tile(head, periods), signal])


# --- the forms ---------------------------------------------------------------------------------


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


@dataclass(frozen=True)
class FormContext:
    """Fixed references of the fit, in SI."""

    reference_pressure: float  # Pa, mean of the training windows' mean p_i
    reference_volume: float  # Pa s, mean over the training samples of the p_b integral
    bore_pressure: float  # Pa, mean measured p_b over the training windows
    prediction_range: dict[str, tuple[float, float]]  # per channel, smallest/largest |y_hat|
    pressure_range: tuple[float, float]  # Pa, lowest and highest window mean p_i


class _LinearForm(ResidualForm):
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


class StaticMap(_LinearForm):
    """``y = y_hat + c0 + c1 y_hat + c2 y_hat^2 + c3 y_hat^3``: a cubic static nonlinearity."""

    name = "static_map"
    phrase = "a static nonlinear map"

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Offset, gain change, quadratic and cubic coefficients."""
        return (
            ("offset", unit),
            ("gain_change", "-"),
            ("quadratic", f"1/{unit}"),
            ("cubic", f"1/{unit}^2"),
        )

    def features(self, data: ChannelSpans) -> FloatArray:
        """``[1, u, u^2, u^3]`` of the normalised prediction ``u``."""
        u = data.baseline
        return np.column_stack([np.ones_like(u), u, u**2, u**3])

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``c0`` (unit), ``c1`` (-), ``c2`` (1/unit), ``c3`` (1/unit^2)."""
        return (x[0] * scale, x[1], x[2] / scale, x[3] / scale**2)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """The local gain ``dy/dy_hat`` at the smallest and the largest reading."""
        _, c1, c2, c3 = values
        unit = CHANNEL_UNITS[channel]
        low, high = context.prediction_range[channel]

        def gain(v: float) -> float:
            return 1.0 + c1 + 2.0 * c2 * v + 3.0 * c3 * v**2

        return (
            f"cubic; gain {gain(low):.3f} at {_quantity(low, unit)} to "
            f"{gain(high):.3f} at {_quantity(high, unit)}"
        )


class LevelGain(_LinearForm):
    """``y = (1 + g0 + g1 (p_seg - p_ref)) y_hat + c0``: a gain that changes with the level."""

    name = "level_gain"
    phrase = "a gain that changes with the pressure level"

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Gain change at the reference pressure, its slope in pressure, offset."""
        return (("gain_change", "-"), ("gain_per_pressure", "1/Pa"), ("offset", unit))

    def features(self, data: ChannelSpans) -> FloatArray:
        """``[u, u (p_seg - p_ref), 1]`` (pressure in MPa)."""
        u = data.baseline
        level = np.concatenate([np.full(p.size, q) for p, q in zip(data.predicted, data.level)])
        return np.column_stack([u, u * level, np.ones_like(u)])

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``g0`` (-), ``g1`` (1/Pa), ``c0`` (unit)."""
        return (x[0], x[1] / MEGA, x[2] * scale)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """The gain at the lowest and the highest level."""
        g0, g1, _ = values
        low, high = context.pressure_range

        def gain(p: float) -> float:
            return 1.0 + g0 + g1 * (p - context.reference_pressure)

        return (
            f"gain {gain(low):.3f} at {_quantity(low, 'Pa')} to {gain(high):.3f} at "
            f"{_quantity(high, 'Pa')} mean p_i"
        )


class FluidLoss(_LinearForm):
    """``y = y_hat + c0 + k (V - V_ref)``, ``V`` the integral of ``p_b`` (a laminar leak)."""

    name = "fluid_loss"
    phrase = "fluid lost from the circuit (a drift with the integral of p_b)"

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Offset and the drift per unit of bore-pressure integral."""
        return (("offset", unit), ("drift_per_pressure_integral", f"{unit}/(Pa s)"))

    def features(self, data: ChannelSpans) -> FloatArray:
        """``[1, V - V_ref]`` (MPa s)."""
        volume = np.concatenate(data.volume)
        return np.column_stack([np.ones_like(volume), volume])

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``c0`` (unit), ``k`` (unit/(Pa s))."""
        return (x[0] * scale, x[1] * scale / MEGA)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """The drift rate at the mean bore pressure."""
        rate = values[1] * context.bore_pressure
        pressure = _quantity(context.bore_pressure, "Pa")
        return f"{_quantity(rate, CHANNEL_UNITS[channel])}/s at {pressure} bore pressure"


class Backlash(ResidualForm):
    """``y = P_w[y_hat] + c0``: a play (backlash) operator of width ``w``."""

    name = "backlash"
    phrase = "hysteresis (a play of fixed width)"

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Width of the play and offset."""
        return (("width", unit), ("offset", unit))

    def predict(self, x: FloatArray, data: ChannelSpans) -> FloatArray:
        """The play operator over each window, warmed up by one period."""
        parts = []
        for u in data.predicted:
            warm = _warm_start(u, data.period_samples, 1)
            parts.append(play(warm, float(x[0]))[warm.size - u.size :])
        return np.asarray(np.concatenate(parts) + x[1], dtype=float)

    def starts(self) -> list[FloatArray]:
        """Widths from 0.5 % to 20 % of the channel's peak-to-peak."""
        return [np.array([w, 0.0]) for w in (0.005, 0.02, 0.05, 0.1, 0.2)]

    def bounds(self, size: int) -> tuple[FloatArray, FloatArray]:
        """Width between 0 and the channel's peak-to-peak."""
        return np.array([0.0, -np.inf]), np.array([1.0, np.inf])

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``w`` (unit), ``c0`` (unit)."""
        return (x[0] * scale, x[1] * scale)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """The play's width."""
        return f"width {_quantity(values[0], CHANNEL_UNITS[channel])}"


class ExtraLag(ResidualForm):
    """``y = L_tau[y_hat] + c0``: an extra first-order lag ``tau y' + y = y_hat``."""

    name = "extra_lag"
    phrase = "an extra lag (first order)"
    shortest = 1e-4  # s
    longest = 0.2  # s

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Time constant and offset."""
        return (("time_constant", "s"), ("offset", unit))

    def predict(self, x: FloatArray, data: ChannelSpans) -> FloatArray:
        """The lag, exact for a linearly interpolated input, warmed up over five time constants."""
        tau = float(np.exp(x[0]))
        pole = math.exp(-data.sample_time / tau)
        ramp = tau / data.sample_time * (1.0 - pole)  # first-order hold (Franklin & Powell)
        b, a = [1.0 - ramp, ramp - pole], [1.0, -pole]
        periods = min(int(np.ceil(5 * tau / (data.period_samples * data.sample_time))) + 1, 10)
        parts = []
        for u in data.predicted:
            warm = _warm_start(u, data.period_samples, periods)
            start = scipy.signal.lfilter_zi(b, a) * warm[0]
            lagged = scipy.signal.lfilter(b, a, warm, zi=start)[0]
            parts.append(lagged[warm.size - u.size :])
        return np.asarray(np.concatenate(parts) + x[1], dtype=float)

    def starts(self) -> list[FloatArray]:
        """Time constants from 0.5 ms to 50 ms."""
        return [np.array([np.log(t), 0.0]) for t in (5e-4, 2e-3, 8e-3, 2e-2, 5e-2)]

    def bounds(self, size: int) -> tuple[FloatArray, FloatArray]:
        """``tau`` between 0.1 ms and 0.2 s."""
        return (
            np.array([np.log(self.shortest), -np.inf]),
            np.array([np.log(self.longest), np.inf]),
        )

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``tau`` (s), ``c0`` (unit)."""
        return (float(np.exp(x[0])), x[1] * scale)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """The time constant."""
        return f"time constant {1e3 * values[0]:.1f} ms"


class Resonance(ResidualForm):
    """``y = y_hat + g z + c0``, ``z'' + 2 zeta omega z' + omega^2 z = -y_hat''``: a mode."""

    name = "resonance"
    phrase = "a resonance (second-order mode)"
    lowest = 20.0  # Hz
    highest = 150.0  # Hz

    def parameter_units(self, unit: str) -> tuple[tuple[str, str], ...]:
        """Natural frequency, damping ratio, gain and offset."""
        return (("frequency", "Hz"), ("damping_ratio", "-"), ("gain", "-"), ("offset", unit))

    def predict(self, x: FloatArray, data: ChannelSpans) -> FloatArray:
        """The mode's relative motion, Tustin-discretised with the frequency prewarped."""
        frequency, zeta, gain = float(x[0]), float(np.exp(x[1])), float(x[2])
        dt = data.sample_time
        _, relative, a = tustin_mode(frequency, zeta, dt)
        b = -relative  # driven by -y_hat''
        decay = 5.0 / (zeta * 2.0 * math.pi * frequency)  # s
        periods = min(int(np.ceil(decay / (data.period_samples * dt))) + 1, 12)
        parts = []
        for u in data.predicted:
            warm = _warm_start(u, data.period_samples, periods)
            mode = scipy.signal.lfilter(b, a, warm - warm[0])  # no response to a constant
            parts.append(u + gain * mode[warm.size - u.size :])
        return np.asarray(np.concatenate(parts) + x[3], dtype=float)

    def starts(self) -> list[FloatArray]:
        """Frequencies across the band, damping 0.1, no gain yet (then gain 1)."""
        return [
            np.array([f, np.log(z), g, 0.0])
            for f in (25.0, 40.0, 65.0, 100.0, 140.0)
            for z in (0.05, 0.2)
            for g in (0.5, -0.5)
        ]

    def bounds(self, size: int) -> tuple[FloatArray, FloatArray]:
        """20-150 Hz, damping ratio 0.02-1, gain within 10."""
        return (
            np.array([self.lowest, np.log(0.02), -10.0, -np.inf]),
            np.array([self.highest, 0.0, 10.0, np.inf]),
        )

    def natural(self, x: FloatArray, scale: float) -> tuple[float, ...]:
        """``f`` (Hz), ``zeta`` (-), ``g`` (-), ``c0`` (unit)."""
        return (float(x[0]), float(np.exp(x[1])), float(x[2]), x[3] * scale)

    def detail(self, values: tuple[float, ...], channel: str, context: FormContext) -> str:
        """Frequency and damping."""
        return f"{values[0]:.0f} Hz, damping ratio {values[1]:.2f}, gain {values[2]:.2f}"


FORMS: tuple[ResidualForm, ...] = (
    StaticMap(),
    Backlash(),
    LevelGain(),
    FluidLoss(),
    ExtraLag(),
    Resonance(),
)
"""The generic forms, in the order of the module docstring."""


def play(signal: FloatArray, width: float) -> FloatArray:
    """The play (backlash) operator of ``width`` (the signal's units), starting centred.

    ``y_k = min(max(y_{k-1}, u_k - w/2), u_k + w/2)``; on a monotone stretch that is
    ``max(y_start, u - w/2)`` (rising) or ``min(y_start, u + w/2)`` (falling), so the loop
    runs over the signal's reversals, not its samples.
    """
    half = 0.5 * width
    output = np.empty_like(signal)
    if signal.size == 0:
        return output
    output[0] = signal[0]
    steps = np.sign(np.diff(signal))
    if steps.size == 0:
        return output
    # A flat step keeps the direction before it.
    nonzero = np.flatnonzero(steps)
    if nonzero.size == 0:
        output[1:] = signal[0]
        return output
    filled = steps[
        nonzero[np.maximum(np.searchsorted(nonzero, np.arange(steps.size), "right") - 1, 0)]
    ]
    breaks = np.flatnonzero(np.diff(filled)) + 1
    previous = float(output[0])
    for first, last in zip(np.r_[0, breaks], np.r_[breaks, steps.size]):
        part = signal[first + 1 : last + 1]
        if filled[first] > 0:
            output[first + 1 : last + 1] = np.maximum(previous, part - half)
        else:
            output[first + 1 : last + 1] = np.minimum(previous, part + half)
        previous = float(output[last])
    return output


# --- fitting the forms -------------------------------------------------------------------------


@dataclass(frozen=True)
class FormFit:
    """One form fitted to one channel's training residual, scored on the held-out windows.

    Costs are mean squared residuals normalised by the channel's peak-to-peak (``scale``),
    as ``Fit.held_out_cost``; ``improvement`` is over all channels (the form on this channel,
    the baseline on the others), ``channel_improvement`` on this channel alone.
    """

    form: str
    channel: str
    phrase: str  # what the form is, in words
    detail: str  # its fitted values, read physically
    parameters: tuple[FormParameter, ...]  # fitted, SI
    constants: tuple[FormParameter, ...]  # fixed references, SI
    train_cost: float
    held_out_cost: float
    channel_improvement: float
    improvement: float

    @property
    def description(self) -> str:
        """The form in words: ``a static nonlinear map of F_k (cubic; ...)``."""
        detail = f" ({self.detail})" if self.detail else ""
        return f"{self.phrase} of {self.channel}{detail}"

    def as_dict(self) -> dict[str, object]:
        """Plain JSON."""
        return {
            "form": self.form,
            "channel": self.channel,
            "description": self.description,
            "parameters": {p.name: p.value for p in self.parameters},
            "units": {p.name: p.unit for p in (*self.parameters, *self.constants)},
            "constants": {p.name: p.value for p in self.constants},
            "train_cost": self.train_cost,
            "held_out_cost": self.held_out_cost,
            "channel_improvement": round(self.channel_improvement, 3),
            "held_out_improvement": round(self.improvement, 3),
        }


def _fit_form(
    form: ResidualForm, train: ChannelSpans, held_out: ChannelSpans
) -> tuple[FloatArray, float, float]:
    """Fitted search-space parameters, training and held-out mean squared residual."""
    target = train.target

    def residual(x: FloatArray) -> FloatArray:
        return np.asarray(form.predict(x, train) - target, dtype=float)

    starts = form.starts()
    low, high = form.bounds(starts[0].size)
    costs = [float(np.mean(residual(np.clip(s, low, high)) ** 2)) for s in starts]
    x0 = np.clip(starts[int(np.argmin(np.nan_to_num(costs, nan=np.inf)))], low, high)
    design = form.jacobian(x0, train)
    with np.errstate(over="ignore", invalid="ignore"):
        if design is not None:
            fixed = design
            result = scipy.optimize.least_squares(
                residual, x0, jac=lambda x: fixed, method="lm", max_nfev=20
            )
        else:
            result = scipy.optimize.least_squares(
                residual, x0, bounds=(low, high), method="trf", x_scale="jac", max_nfev=60
            )
    x = np.asarray(result.x, dtype=float)
    train_cost = float(np.mean(residual(x) ** 2))
    held_out_cost = float(np.mean((form.predict(x, held_out) - held_out.target) ** 2))
    if not np.isfinite(held_out_cost):  # a form that cannot describe the data at all
        held_out_cost = math.inf
    return x, train_cost, held_out_cost


# --- describing the misfit ---------------------------------------------------------------------


@dataclass(frozen=True)
class ChannelMisfit:
    """What the baseline's misfit of one channel looks like (fractions of its energy).

    ``static_fraction``: share of the misfit's energy (sum of squares) a cubic map of the
    prediction explains; ``rate_fraction``: the share terms in ``dy_hat/dt`` and its sign
    explain on top of it. ``asymmetry``: ``(E_apply - E_release) / (E_apply + E_release)`` at
    the same levels of the prediction (positive: larger while the prediction rises).
    Per segment, the mean misfit over the segment's swing (signed as the channel) and the gain
    error (``dy/dy_hat - 1``): ``level_variation`` is the change across the segments of
    whichever changes more (in misfit units) over the misfit's typical RMS relative to the
    swing, ``level_trend`` its Spearman correlation with the segment's mean pressure, positive
    when the measured channel grows relative to the prediction as the level rises. The
    calibration centres a misfit that grows with the level (it changes sign across the
    segments), so the trend, not the size at each level, says whether it grows.
    ``segment_misfit``: RMS misfit over each segment's peak-to-peak, lowest pressure first.
    ``drift_fraction``: share of the within-segment variance of the cycle means a linear trend
    in time explains;
    ``drift_size``: that trend's largest change over a segment over the misfit's RMS.
    """

    channel: str
    share: float  # of the baseline's held-out error (normalised), over channels
    held_out_nrmse: float  # the baseline's, over the channel's peak-to-peak
    static_fraction: float
    rate_fraction: float
    asymmetry: float
    level_variation: float
    level_trend: float
    segment_misfit: tuple[float, ...]
    drift_fraction: float
    drift_size: float

    @property
    def static(self) -> bool:
        """A static map of the prediction explains most of the misfit."""
        return self.static_fraction >= STATIC_SHARE and self.static_fraction > self.rate_fraction

    @property
    def dynamic(self) -> bool:
        """The misfit depends on the prediction's rate more than on its value."""
        return self.rate_fraction >= RATE_SHARE and self.rate_fraction > self.static_fraction

    @property
    def symmetric(self) -> bool:
        """Apply and release carry the same misfit at the same levels."""
        return abs(self.asymmetry) <= ASYMMETRY_LIMIT

    @property
    def level_dependent(self) -> bool:
        """The misfit changes, monotonically, with the pressure level."""
        return self.level_variation >= LEVEL_VARIATION and abs(self.level_trend) >= 0.9

    @property
    def grows_with_pressure(self) -> bool:
        """The measured channel grows relative to the prediction as the level rises."""
        return self.level_dependent and self.level_trend > 0

    @property
    def drifts(self) -> bool:
        """The misfit's cycle means follow a trend in time within the segments."""
        return self.drift_fraction >= DRIFT_SHARE and self.drift_size >= DRIFT_SIZE

    def as_dict(self) -> dict[str, object]:
        """Plain JSON, flags included."""
        return {
            "share": round(self.share, 4),
            "held_out_nrmse": self.held_out_nrmse,
            "static_fraction": round(self.static_fraction, 4),
            "rate_fraction": round(self.rate_fraction, 4),
            "asymmetry": round(self.asymmetry, 4),
            "level_variation": round(self.level_variation, 4),
            "level_trend": round(self.level_trend, 4),
            "segment_misfit": [round(v, 5) for v in self.segment_misfit],
            "drift_fraction": round(self.drift_fraction, 4),
            "drift_size": round(self.drift_size, 4),
            "static": self.static,
            "dynamic": self.dynamic,
            "symmetric": self.symmetric,
            "level_dependent": self.level_dependent,
            "grows_with_pressure": self.grows_with_pressure,
            "drifts": self.drifts,
        }


def _explained(design: FloatArray, target: FloatArray, total: float) -> float:
    """Share of ``total`` (sum of squares of ``target``) a least-squares fit explains."""
    coefficients = np.linalg.lstsq(design, target, rcond=None)[0]
    return float(1.0 - np.sum((target - design @ coefficients) ** 2) / total)


def _spearman(values: Sequence[float], levels: Sequence[float]) -> float:
    """Rank correlation of ``values`` with ``levels`` (0 for fewer than two)."""
    if len(values) < 2 or float(np.ptp(values)) == 0.0:
        return 0.0
    a = np.argsort(np.argsort(values)).astype(float)
    b = np.argsort(np.argsort(levels)).astype(float)
    return float(np.corrcoef(a, b)[0, 1])


def _characterise(
    channel: str, data: ChannelSpans, pressures: Mapping[int, float], share: float, nrmse: float
) -> ChannelMisfit:
    """Describe one channel's misfit over all its windows (see :class:`ChannelMisfit`)."""
    u = data.baseline
    r = data.target - u
    total = max(float(np.sum(r**2)), 1e-300)
    rate = np.concatenate([np.gradient(p, data.sample_time) for p in data.predicted])
    centred = (u - u.mean()) / max(float(u.std()), 1e-12)
    speed = rate / max(float(np.sqrt(np.mean(rate**2))), 1e-12)
    sign = np.sign(rate)
    static_design = np.column_stack([np.ones_like(u), centred, centred**2, centred**3])
    rate_design = np.column_stack([speed, speed * centred, sign, sign * centred])
    static_fraction = _explained(static_design, r, total)
    rate_fraction = _explained(np.hstack([static_design, rate_design]), r, total) - static_fraction

    # Apply against release at the same levels of the prediction.
    edges = np.quantile(centred, np.linspace(0.0, 1.0, 11)[1:-1])
    bins = np.digitize(centred, edges)
    apply_energy = release_energy = 0.0
    for b in range(10):
        rising = r[(bins == b) & (rate > 0)]
        falling = r[(bins == b) & (rate < 0)]
        if rising.size >= 5 and falling.size >= 5:
            apply_energy += float(np.mean(rising**2))
            release_energy += float(np.mean(falling**2))
    asymmetry = (apply_energy - release_energy) / max(apply_energy + release_energy, 1e-300)

    # Segments: each one's mean misfit and gain error, relative to its own swing.
    owner = np.repeat(np.array(data.segment), [p.size for p in data.predicted])
    segments = sorted(set(data.segment), key=lambda s: pressures[s])
    alphas, betas, misfits, spread = [], [], [], []
    for s in segments:
        inside = owner == s
        width = max(float(np.ptp(u[inside])), 1e-12)
        deviation = u[inside] - u[inside].mean()
        betas.append(
            float(np.dot(deviation, r[inside])) / max(float(np.dot(deviation, deviation)), 1e-300)
        )
        alphas.append(float(r[inside].mean()) / width * float(np.sign(u[inside].mean())))
        misfits.append(float(np.sqrt(np.mean(r[inside] ** 2))) / width)
        spread.append(float(np.sqrt(np.mean(deviation**2))) / width)
    # Each coefficient's change across the levels in the misfit's units (a gain error beta
    # moves the misfit by beta times the swing's RMS).
    change_alpha = float(np.ptp(alphas))
    change_beta = float(np.ptp(betas)) * float(np.mean(spread))
    trend_of = alphas if change_alpha >= change_beta else betas
    typical = max(float(np.sqrt(np.mean(np.square(misfits)))), 1e-300)
    level_variation = max(change_alpha, change_beta) / typical if len(segments) > 1 else 0.0
    level_trend = _spearman(trend_of, [pressures[s] for s in segments])

    # Drift: the cycle means' trend in time within each segment.
    m = data.period_samples
    explained = within = 0.0
    largest_change = 0.0
    for s in segments:
        means, times = [], []
        for p, y, t, seg in zip(data.predicted, data.measured, data.time, data.segment):
            if seg != s:
                continue
            cycles = p.size // m
            if cycles:
                residual = (y - p)[: cycles * m].reshape(cycles, m)
                means.extend(residual.mean(axis=1).tolist())
                times.extend(t[: cycles * m].reshape(cycles, m).mean(axis=1).tolist())
        if len(means) < 3:
            continue
        c = np.array(means) - np.mean(means)
        tc = np.array(times) - np.mean(times)
        slope = float(np.dot(tc, c) / max(float(np.dot(tc, tc)), 1e-300))
        explained += slope**2 * float(np.dot(tc, tc))
        within += float(np.dot(c, c))
        largest_change = max(largest_change, abs(slope) * float(np.ptp(times)))
    drift_fraction = explained / within if within > 0 else 0.0
    drift_size = largest_change / max(float(np.sqrt(np.mean(r**2))), 1e-300)
    return ChannelMisfit(
        channel=channel,
        share=share,
        held_out_nrmse=nrmse,
        static_fraction=static_fraction,
        rate_fraction=rate_fraction,
        asymmetry=asymmetry,
        level_variation=level_variation,
        level_trend=level_trend,
        segment_misfit=tuple(misfits),
        drift_fraction=drift_fraction,
        drift_size=drift_size,
    )


# --- the result --------------------------------------------------------------------------------


@dataclass(frozen=True)
class ResidualDescription:
    """What the baseline's misfit looks like and the generic forms that describe it.

    The flags are those of ``channel``, the channel that carries most of the held-out error;
    ``channels`` holds every channel's. ``forms`` are ranked by held-out improvement (all
    channels); ``best`` is the first when it stands out (cuts the held-out error
    ``STANDS_OUT_RATIO`` times while the misfit is ``NOISE_EXCESS`` times the noise), else None.
    """

    channel: str
    channels: tuple[ChannelMisfit, ...]
    forms: tuple[FormFit, ...]
    best: FormFit | None
    baseline_cost: float  # mean over channels of the held-out normalised mean squared error
    noise_cost: float | None  # the noise's share of it (Dataset.noise_cost), when known
    summary: str

    def misfit(self, channel: str | None = None) -> ChannelMisfit:
        """The description of ``channel`` (default: the one carrying most of the misfit)."""
        key = self.channel if channel is None else channel
        return next(c for c in self.channels if c.channel == key)

    @property
    def shares(self) -> dict[str, float]:
        """Each channel's share of the baseline's held-out error (normalised, sums to 1)."""
        return {c.channel: c.share for c in self.channels}

    @property
    def static(self) -> bool:
        """A static map of the prediction explains most of the misfit."""
        return self.misfit().static

    @property
    def dynamic(self) -> bool:
        """The misfit depends on the prediction's rate more than on its value."""
        return self.misfit().dynamic

    @property
    def symmetric(self) -> bool:
        """Apply and release carry the same misfit."""
        return self.misfit().symmetric

    @property
    def level_dependent(self) -> bool:
        """The misfit changes monotonically with the pressure level."""
        return self.misfit().level_dependent

    @property
    def grows_with_pressure(self) -> bool:
        """The misfit changes with the level and is largest at the highest level."""
        return self.misfit().grows_with_pressure

    @property
    def drifts(self) -> bool:
        """The misfit drifts in time within the segments."""
        return self.misfit().drifts

    def reworded(self, verdict: str) -> ResidualDescription:
        """The same description, its summary starting with ``verdict``.

        On a diagnosis whose verdict names an effect (or none), the misfit described is the
        calibrated baseline's, not an ``unexplained`` one.
        """
        excess = _excess(self.baseline_cost, self.noise_cost, self.forms)
        summary = _summarise(verdict, self.misfit(), self.forms, self.best, excess)
        return replace(self, summary=summary)

    def verdict_entry(self) -> dict[str, object] | None:
        """``verdict.unexplained_form`` of interface.md (None when nothing stands out)."""
        if self.best is None:
            return None
        return {
            "description": self.best.description,
            "form": self.best.form,
            "channel": self.best.channel,
            "improvement": round(self.best.improvement, 3),
        }

    def as_dict(self) -> dict[str, object]:
        """Plain JSON for ``diagnosis.json``."""
        return {
            "summary": self.summary,
            "channel": self.channel,
            "shares": {k: round(v, 4) for k, v in self.shares.items()},
            "flags": {
                "static": self.static,
                "dynamic": self.dynamic,
                "symmetric": self.symmetric,
                "level_dependent": self.level_dependent,
                "grows_with_pressure": self.grows_with_pressure,
                "drifts": self.drifts,
            },
            "channels": {c.channel: c.as_dict() for c in self.channels},
            "best": None if self.best is None else self.best.as_dict(),
            "forms": [f.as_dict() for f in self.forms],
            "baseline_cost": self.baseline_cost,
            "noise_cost": self.noise_cost,
        }


def _quantity(value: float, unit: str) -> str:
    """A value with its unit at a readable scale (MPa, kN, um)."""
    if unit == "Pa":
        return f"{value / 1e6:.2f} MPa"
    if unit == "N":
        return f"{value / 1e3:.2f} kN"
    if unit == "m":
        return f"{value * 1e6:.1f} um"
    return f"{value:.3g} {unit}"


def _character_words(misfit: ChannelMisfit) -> list[str]:
    """The flags in words."""
    words = []
    if misfit.static:
        words.append("static")
    elif misfit.dynamic:
        words.append("rate-dependent")
    if misfit.level_dependent:
        words.append(
            "growing with pressure" if misfit.level_trend > 0 else "falling with pressure"
        )
    else:
        words.append("not changing with pressure")
    if misfit.symmetric:
        words.append("symmetric")
    else:
        larger = "apply" if misfit.asymmetry > 0 else "release"
        words.append(f"asymmetric (larger on {larger})")
    if misfit.drifts:
        words.append("drifting")
    return words


def _excess(
    baseline_cost: float, noise_cost: float | None, ranked: Sequence[FormFit]
) -> float | None:
    """The baseline's held-out error over the noise's share (None when the noise is unknown).

    No form fitted on training predicts held-out noise, so the noise's share is at most what
    the best form left.
    """
    floor = noise_cost
    if floor is not None and ranked:
        floor = min(floor, baseline_cost / max(ranked[0].improvement, 1.0))
    return None if floor is None else baseline_cost / max(floor, 1e-300)


def _summarise(
    verdict: str,
    misfit: ChannelMisfit,
    forms: Sequence[FormFit],
    best: FormFit | None,
    excess: float | None,
) -> str:
    """The one sentence of :attr:`ResidualDescription.summary`."""
    carried = f"carried by {misfit.channel} ({100 * misfit.share:.0f} % of the held-out error)"
    character = ", ".join([carried, *_character_words(misfit)])
    if best is not None:
        return (
            f"{verdict}; looks like {best.description}, {character}; that form cuts the "
            f"held-out error {best.improvement:.1f} times"
        )
    if excess is not None and excess < NOISE_EXCESS:
        reason = (
            f"the baseline's held-out error is only {excess:.1f} times the measurement noise's "
            "share"
        )
    else:
        top = forms[0]
        reason = (
            f"no generic form cuts the held-out error {STANDS_OUT_RATIO:g} times (best: "
            f"{top.phrase} of {top.channel}, {top.improvement:.2f} times)"
        )
    return f"{verdict}; nothing stands out: {reason}; the misfit is {character}"


# --- the entry point ---------------------------------------------------------------------------


def _spans(
    dataset: Dataset,
    windows: Sequence[Window],
    predictions: Mapping[Window, FloatArray],
    channel: int,
    volume: FloatArray,
    context: FormContext,
) -> ChannelSpans:
    """One channel over ``windows``, normalised (see :class:`ChannelSpans`)."""
    key = OUTPUT_CHANNELS[channel]
    scale = max(dataset.scale()[key], 1e-300)
    predicted, measured, times, volumes = [], [], [], []
    for window in windows:
        inside = dataset.mask((window,))
        predicted.append(np.asarray(predictions[window][channel], dtype=float) / scale)
        measured.append(dataset.measured[key][inside] / scale)
        times.append(dataset.time[inside])
        volumes.append((volume[inside] - context.reference_volume) / MEGA)
    return ChannelSpans(
        predicted=predicted,
        measured=measured,
        level=[(w.mean_pressure - context.reference_pressure) / MEGA for w in windows],
        volume=volumes,
        time=times,
        segment=[w.segment for w in windows],
        sample_time=dataset.sample_time,
        period_samples=max(int(round(dataset.period / dataset.sample_time)), 1),
    )


def _check(dataset: Dataset, predictions: Mapping[Window, FloatArray]) -> None:
    """Refuse predictions that do not cover every window with (3, n) finite samples."""
    for window in (*dataset.train, *dataset.held_out):
        if window not in predictions:
            raise ValueError(
                f"{dataset.name}: no baseline prediction for the window "
                f"{window.start:.3f}-{window.end:.3f} s"
            )
        expected = (len(OUTPUT_CHANNELS), int(np.count_nonzero(dataset.mask((window,)))))
        shape = np.shape(predictions[window])
        if shape != expected:
            raise ValueError(
                f"{dataset.name}: the prediction over {window.start:.3f}-{window.end:.3f} s has "
                f"shape {shape} but should be {expected} (p_b, F_k, x_c by sample)"
            )
        if not np.all(np.isfinite(predictions[window])):
            raise ValueError(
                f"{dataset.name}: the prediction over {window.start:.3f}-{window.end:.3f} s is "
                "not finite"
            )


def describe_residual(
    dataset: Dataset,
    predictions: Mapping[Window, FloatArray],
    *,
    noise_cost: float | None = None,
    verdict: str = "unexplained",
    forms: Sequence[ResidualForm] = FORMS,
) -> ResidualDescription:
    """Describe the baseline's misfit and rank generic forms of it (see the module docstring).

    Args:
        dataset: the prepared recording (:func:`brake_hil.diagnosis.dataset.prepare`).
        predictions: the calibrated baseline's outputs (3, n) (p_b Pa, F_k N, x_c m) over
            every window of ``dataset.train`` and ``dataset.held_out``, at the samples
            ``dataset.mask((window,))`` selects (:func:`baseline_predictions`).
        noise_cost: the measurement noise's share of the held-out cost
            (``dataset.noise_cost()``); when given, nothing stands out while the baseline's
            held-out cost is under ``NOISE_EXCESS`` times it.
        verdict: the word the summary starts with.
        forms: the forms to fit (default: all six).

    Returns:
        The description; its ``summary`` is one sentence.

    Raises:
        ValueError: a window without a prediction, or one of the wrong shape or not finite.
    """
    _check(dataset, predictions)
    train_windows, held_windows = tuple(dataset.train), tuple(dataset.held_out)
    scale = dataset.scale()
    volume = np.concatenate(
        [
            [0.0],
            np.cumsum(
                0.5
                * (dataset.measured["p_b"][1:] + dataset.measured["p_b"][:-1])
                * np.diff(dataset.time)
            ),
        ]
    )
    train_mask = dataset.mask(train_windows)
    everything = (*train_windows, *held_windows)
    prediction_range = {}
    for c, key in enumerate(OUTPUT_CHANNELS):
        magnitudes = np.abs(np.concatenate([predictions[w][c] for w in everything]))
        extremes = np.concatenate([predictions[w][c] for w in everything])
        prediction_range[key] = (
            float(extremes[np.argmin(magnitudes)]),
            float(extremes[np.argmax(magnitudes)]),
        )
    context = FormContext(
        reference_pressure=float(np.mean([w.mean_pressure for w in train_windows])),
        reference_volume=float(np.mean(volume[train_mask])),
        bore_pressure=float(np.mean(dataset.measured["p_b"][train_mask])),
        prediction_range=prediction_range,
        pressure_range=(
            min(w.mean_pressure for w in everything),
            max(w.mean_pressure for w in everything),
        ),
    )
    pressures = {w.segment: w.mean_pressure for w in everything}
    train_data, held_data, all_data, baseline_costs = [], [], [], []
    for c in range(len(OUTPUT_CHANNELS)):
        train = _spans(dataset, train_windows, predictions, c, volume, context)
        held = _spans(dataset, held_windows, predictions, c, volume, context)
        train_data.append(train)
        held_data.append(held)
        all_data.append(_spans(dataset, everything, predictions, c, volume, context))
        baseline_costs.append(float(np.mean((held.target - held.baseline) ** 2)))
    total = max(sum(baseline_costs), 1e-300)
    baseline_cost = total / len(OUTPUT_CHANNELS)
    misfits = tuple(
        _characterise(
            key, all_data[c], pressures, baseline_costs[c] / total, math.sqrt(baseline_costs[c])
        )
        for c, key in enumerate(OUTPUT_CHANNELS)
    )
    fitted = []
    for c, key in enumerate(OUTPUT_CHANNELS):
        unit = CHANNEL_UNITS[key]
        for form in forms:
            x, train_cost, held_cost = _fit_form(form, train_data[c], held_data[c])
            values = form.natural(x, scale[key])
            overall = (total - baseline_costs[c] + held_cost) / len(OUTPUT_CHANNELS)
            constants = {
                LevelGain.name: (
                    FormParameter("reference_pressure", context.reference_pressure, "Pa"),
                ),
                FluidLoss.name: (
                    FormParameter("reference_pressure_integral", context.reference_volume, "Pa s"),
                ),
            }.get(form.name, ())
            fitted.append(
                FormFit(
                    form=form.name,
                    channel=key,
                    phrase=form.phrase,
                    detail=form.detail(values, key, context),
                    parameters=tuple(
                        FormParameter(name, float(v), u)
                        for (name, u), v in zip(form.parameter_units(unit), values)
                    ),
                    constants=constants,
                    train_cost=train_cost,
                    held_out_cost=held_cost,
                    channel_improvement=baseline_costs[c] / max(held_cost, 1e-300),
                    improvement=baseline_cost / max(overall, 1e-300),
                )
            )
    ranked = tuple(sorted(fitted, key=lambda f: f.improvement, reverse=True))
    excess = _excess(baseline_cost, noise_cost, ranked)
    stands_out = bool(ranked) and ranked[0].improvement >= STANDS_OUT_RATIO
    if excess is not None and excess < NOISE_EXCESS:
        stands_out = False
    best = ranked[0] if stands_out else None
    dominant = max(misfits, key=lambda m: m.share)
    return ResidualDescription(
        channel=dominant.channel,
        channels=misfits,
        forms=ranked,
        best=best,
        baseline_cost=baseline_cost,
        noise_cost=noise_cost,
        summary=_summarise(verdict, dominant, ranked, best, excess),
    )
