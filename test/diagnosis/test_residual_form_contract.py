"""Every registered residual form keeps the one small interface (one contract, all forms)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from brake_hil.diagnosis.residual_forms import (
    CHANNEL_UNITS,
    FORM_ORDER,
    FORMS,
    ChannelSpans,
    FormContext,
    FormParameter,
    ResidualForm,
    register_form,
    registered_forms,
)
from brake_hil.diagnosis.residual_forms.fitting import fit_form

SAMPLE_TIME = 0.002  # s
PERIOD_SAMPLES = 100  # a 5 Hz cycle


def _spans(measured_from: ResidualForm | None = None, x: np.ndarray | None = None) -> ChannelSpans:
    """Two windows of a normalised 5 Hz prediction at two levels; measured = prediction.

    With ``measured_from`` and ``x``, the measured channel is what that form predicts.
    """
    time = [np.arange(0, 2.0, SAMPLE_TIME), np.arange(3.0, 5.0, SAMPLE_TIME)]
    predicted = [
        0.4 * np.sin(2 * np.pi * 5.0 * t) + 0.1 * np.sin(2 * np.pi * 10.0 * t) + 0.5 for t in time
    ]
    spans = ChannelSpans(
        predicted=predicted,
        measured=[p.copy() for p in predicted],
        level=[-0.7, 0.7],  # MPa
        volume=[np.linspace(-1.0, 0.0, t.size) for t in time[:1]]
        + [np.linspace(0.2, 1.2, time[1].size)],  # MPa s
        time=time,
        segment=[0, 1],
        sample_time=SAMPLE_TIME,
        period_samples=PERIOD_SAMPLES,
    )
    if measured_from is None or x is None:
        return spans
    target = measured_from.predict(x, spans)
    sizes = np.cumsum([p.size for p in predicted])[:-1]
    return dataclasses.replace(spans, measured=np.split(target, sizes))


CONTEXT = FormContext(
    reference_pressure=3.0e6,
    reference_volume=4.0e6,
    bore_pressure=2.5e6,
    prediction_range={"p_b": (1.0e6, 5.0e6), "F_k": (1.0e3, 8.0e3), "x_c": (1e-6, 3e-5)},
    pressure_range=(1.4e6, 4.1e6),
)


def test_the_library_forms_are_registered_once_in_their_order() -> None:
    names = [form.name for form in FORMS]
    assert names == list(FORM_ORDER) and len(set(names)) == len(names)
    assert tuple(registered_forms()) == FORMS


def test_a_second_form_of_the_same_name_is_refused() -> None:
    with pytest.raises(ValueError, match="registered already"):
        register_form(type(FORMS[0]))


@pytest.mark.parametrize("form", FORMS, ids=lambda f: f.name)
def test_a_form_keeps_the_interface(form: ResidualForm) -> None:
    """Parameters, starts and bounds agree in size; the prediction is finite and in shape."""
    units = form.parameter_units("Pa")
    starts = form.starts()
    assert form.phrase and units and starts
    low, high = form.bounds(starts[0].size)
    assert all(s.shape == (len(units),) for s in starts)
    assert low.shape == high.shape == (len(units),) and np.all(low < high)
    data = _spans()
    for start in starts:
        x = np.clip(start, low, high)
        predicted = form.predict(x, data)
        assert predicted.shape == data.target.shape and np.all(np.isfinite(predicted))
        values = form.natural(x, 2.0e6)
        assert len(values) == len(units) and all(np.isfinite(values))
    jacobian = form.jacobian(starts[0], data)
    assert jacobian is None or jacobian.shape == (data.target.size, len(units))
    for channel in CHANNEL_UNITS:
        assert isinstance(form.detail(form.natural(starts[0], 1.0), channel, CONTEXT), str)
    assert all(isinstance(c, FormParameter) for c in form.constants(CONTEXT))


@pytest.mark.parametrize("form", FORMS, ids=lambda f: f.name)
def test_a_form_fitted_to_its_own_prediction_explains_it(form: ResidualForm) -> None:
    """A misfit the form itself makes is what the fit removes, on the held-out windows too."""
    starts = form.starts()
    low, high = form.bounds(starts[0].size)
    truth = np.clip(starts[len(starts) // 2], low, high)
    truth[-1] += 0.05  # away from the start point the fit begins at
    data = _spans(form, truth)
    misfit = float(np.mean((data.target - data.baseline) ** 2))
    _, train_cost, held_out_cost = fit_form(form, data, data)
    assert train_cost < 0.01 * misfit and held_out_cost < 0.01 * misfit
