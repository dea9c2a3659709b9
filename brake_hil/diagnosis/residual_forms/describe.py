"""The entry points: the baseline's predictions, and the description of its misfit."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
import math
from typing import Protocol

import numpy as np

from brake_hil.diagnosis.dataset import Dataset, Window
from brake_hil.diagnosis.residual_forms.base import (
    CHANNEL_UNITS,
    MEGA,
    ChannelSpans,
    FormContext,
    FormParameter,
    ResidualForm,
    registered_forms,
)
from brake_hil.diagnosis.residual_forms.description import (
    NOISE_EXCESS,
    STANDS_OUT_RATIO,
    ResidualDescription,
    summarise,
    times_noise,
)
from brake_hil.diagnosis.residual_forms.fitting import FormFit, fit_form
from brake_hil.diagnosis.residual_forms.misfit import characterise
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray, IndexArray

__all__ = ["WindowSimulator", "baseline_predictions", "describe_residual"]


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
    forms: Sequence[ResidualForm] | None = None,
) -> ResidualDescription:
    """Describe the baseline's misfit and rank generic forms of it (see the package docstring).

    Args:
        dataset: the prepared recording (:func:`brake_hil.diagnosis.dataset.prepare`).
        predictions: the calibrated baseline's outputs (3, n) (p_b Pa, F_k N, x_c m) over
            every window of ``dataset.train`` and ``dataset.held_out``, at the samples
            ``dataset.mask((window,))`` selects (:func:`baseline_predictions`).
        noise_cost: the measurement noise's share of the held-out cost
            (``dataset.noise_cost()``); when given, nothing stands out while the baseline's
            held-out cost is under ``NOISE_EXCESS`` times it.
        verdict: the word the summary starts with.
        forms: the forms to fit (default: every registered one, ``FORMS``).

    Returns:
        The description; its ``summary`` is one sentence.

    Raises:
        ValueError: a window without a prediction, or one of the wrong shape or not finite.
    """
    _check(dataset, predictions)
    volume = _pressure_integral(dataset)
    context = _context(dataset, predictions, volume)
    data = _Channels.of(dataset, predictions, volume, context)
    everything = (*dataset.train, *dataset.held_out)
    pressures = {w.segment: w.mean_pressure for w in everything}
    total = max(sum(data.baseline_costs), 1e-300)
    baseline_cost = total / len(OUTPUT_CHANNELS)
    misfits = tuple(
        characterise(
            key,
            data.everything[c],
            pressures,
            data.baseline_costs[c] / total,
            math.sqrt(data.baseline_costs[c]),
        )
        for c, key in enumerate(OUTPUT_CHANNELS)
    )
    chosen = registered_forms() if forms is None else forms
    scale = dataset.scale()
    fitted = [
        _fitted(form, c, data, scale[key], context, total)
        for c, key in enumerate(OUTPUT_CHANNELS)
        for form in chosen
    ]
    ranked = tuple(sorted(fitted, key=lambda f: f.improvement, reverse=True))
    excess = times_noise(baseline_cost, noise_cost, ranked)
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
        summary=summarise(verdict, dominant, ranked, best, excess),
    )


def _pressure_integral(dataset: Dataset) -> FloatArray:
    """The integral of the measured bore pressure from the recording's start (Pa s)."""
    p_b = dataset.measured["p_b"]
    steps = 0.5 * (p_b[1:] + p_b[:-1]) * np.diff(dataset.time)
    return np.asarray(np.concatenate([[0.0], np.cumsum(steps)]), dtype=float)


def _context(
    dataset: Dataset, predictions: Mapping[Window, FloatArray], volume: FloatArray
) -> FormContext:
    """The fit's fixed references (:class:`FormContext`)."""
    train_windows = tuple(dataset.train)
    everything = (*train_windows, *dataset.held_out)
    train_mask = dataset.mask(train_windows)
    prediction_range = {}
    for c, key in enumerate(OUTPUT_CHANNELS):
        magnitudes = np.abs(np.concatenate([predictions[w][c] for w in everything]))
        extremes = np.concatenate([predictions[w][c] for w in everything])
        prediction_range[key] = (
            float(extremes[np.argmin(magnitudes)]),
            float(extremes[np.argmax(magnitudes)]),
        )
    return FormContext(
        reference_pressure=float(np.mean([w.mean_pressure for w in train_windows])),
        reference_volume=float(np.mean(volume[train_mask])),
        bore_pressure=float(np.mean(dataset.measured["p_b"][train_mask])),
        prediction_range=prediction_range,
        pressure_range=(
            min(w.mean_pressure for w in everything),
            max(w.mean_pressure for w in everything),
        ),
    )


@dataclass(frozen=True)
class _Channels:
    """Every output channel over the training, the held-out and all windows (normalised)."""

    train: list[ChannelSpans]
    held_out: list[ChannelSpans]
    everything: list[ChannelSpans]
    baseline_costs: list[float]  # per channel, the baseline's held-out mean squared misfit

    @staticmethod
    def of(
        dataset: Dataset,
        predictions: Mapping[Window, FloatArray],
        volume: FloatArray,
        context: FormContext,
    ) -> _Channels:
        """The spans of every channel, by channel in ``OUTPUT_CHANNELS`` order."""
        train_windows, held_windows = tuple(dataset.train), tuple(dataset.held_out)
        everything = (*train_windows, *held_windows)
        channels = _Channels([], [], [], [])
        for c in range(len(OUTPUT_CHANNELS)):
            held = _spans(dataset, held_windows, predictions, c, volume, context)
            channels.train.append(_spans(dataset, train_windows, predictions, c, volume, context))
            channels.held_out.append(held)
            channels.everything.append(
                _spans(dataset, everything, predictions, c, volume, context)
            )
            channels.baseline_costs.append(float(np.mean((held.target - held.baseline) ** 2)))
        return channels


def _fitted(
    form: ResidualForm,
    c: int,
    data: _Channels,
    scale: float,
    context: FormContext,
    total: float,
) -> FormFit:
    """``form`` fitted to channel ``c`` (of peak-to-peak ``scale``) and scored on held-out.

    ``total``: the sum over channels of the baseline's held-out mean squared misfit.
    """
    key = OUTPUT_CHANNELS[c]
    unit = CHANNEL_UNITS[key]
    baseline_cost = data.baseline_costs[c]
    x, train_cost, held_cost = fit_form(form, data.train[c], data.held_out[c])
    values = form.natural(x, scale)
    overall = (total - baseline_cost + held_cost) / len(OUTPUT_CHANNELS)
    low, high = form.bounds(x.size)
    pinned = bool(np.any(np.isclose(x, low) | np.isclose(x, high)))
    detail = form.detail(values, key, context)
    return FormFit(
        form=form.name,
        channel=key,
        phrase=form.phrase,
        detail=f"{detail} (a value held at the limit of its fit range)" if pinned else detail,
        parameters=tuple(
            FormParameter(name, float(v), u)
            for (name, u), v in zip(form.parameter_units(unit), values)
        ),
        constants=form.constants(context),
        train_cost=train_cost,
        held_out_cost=held_cost,
        channel_improvement=baseline_cost / max(held_cost, 1e-300),
        improvement=total / len(OUTPUT_CHANNELS) / max(overall, 1e-300),
    )
