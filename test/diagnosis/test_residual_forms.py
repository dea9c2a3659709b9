"""Generic forms of an unexplained misfit: each form, when it made the data, is found first.

The synthetic recordings are built here with no simulation: a smooth pulsing "prediction" of
the three channels at three pressure levels, and a "measurement" that is the prediction passed
through a known form (computed over the whole record, independently of the module's own
implementation) plus noise. One integration test calibrates the LTI baseline to a virtual-rig
recording of the out-of-library ``sensor_nonlinearity``.
"""

from __future__ import annotations

from collections.abc import Callable
import dataclasses
import json
from typing import Any

import numpy as np
import pytest
import scipy.signal

from brake_hil.diagnosis.calibration import calibrate
from brake_hil.diagnosis.dataset import Dataset, Window, prepare
from brake_hil.diagnosis.fitting import Model, fit
from brake_hil.diagnosis.residual_forms import (
    FORMS,
    ResidualDescription,
    baseline_predictions,
    describe_residual,
    play,
)
from brake_hil.physics.excitation import SEED_MAX_PRESSURES
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray
from brake_hil.virtual_rig.cases import nominal_rigs
from brake_hil.virtual_rig.effects import make_effect
from brake_hil.virtual_rig.excitation import seed_pulsing
from brake_hil.virtual_rig.simulator import simulate_rig

SAMPLE_TIME = 0.002  # s, the diagnosis rate
PERIOD = 0.2  # s, 5 Hz pulsing
LEVELS = (1.08e6, 1.61e6, 2.15e6)  # Pa, mean p_i of the three segments
SEGMENT_START = 2.2  # s after each level's ramp begins
TRAIN_CYCLES, HELD_OUT_CYCLES = 11, 7
NOISE = 0.002  # of each channel's peak-to-peak, one sigma

Transform = Callable[["Record"], dict[str, FloatArray]]


@dataclasses.dataclass(frozen=True)
class Record:
    """A whole synthetic record: time (s), p_i (Pa), the level (Pa), predicted channels."""

    time: FloatArray
    pressure: FloatArray
    level: FloatArray
    predicted: dict[str, FloatArray]


def synthetic_record() -> Record:
    time = np.arange(0.0, 18.0, SAMPLE_TIME)
    corners_t, corners_p = [0.0], [0.0]
    for k, level in enumerate(LEVELS):
        corners_t += [6.0 * k + 1.0, 6.0 * k + 6.0]
        corners_p += [level, level]
    level = np.interp(time, corners_t, corners_p)
    wave = np.tanh(2.0 * np.sin(2 * np.pi * time / PERIOD)) / np.tanh(2.0)  # rounded square
    pressure = level * (1.0 + 0.2 * wave)
    pole = np.exp(-SAMPLE_TIME / 0.01)
    bore = scipy.signal.lfilter([1 - pole], [1, -pole], pressure)
    predicted = {"p_b": bore, "F_k": 2.4e-3 * bore, "x_c": -7.0e-11 * bore}
    return Record(time, pressure, level, predicted)


def windows() -> tuple[tuple[Window, ...], tuple[Window, ...], tuple[Window, ...]]:
    train, held_out, segments = [], [], []
    for k, level in enumerate(LEVELS):
        start = 6.0 * k + SEGMENT_START
        cut = start + TRAIN_CYCLES * PERIOD
        end = cut + HELD_OUT_CYCLES * PERIOD
        segments.append(Window(start, end, level, k))
        train.append(Window(start, cut, level, k))
        held_out.append(Window(cut, end, level, k))
    return tuple(train), tuple(held_out), tuple(segments)


def make_case(
    transform: Transform | None, seed: int = 0
) -> tuple[Dataset, dict[Window, FloatArray]]:
    """The dataset whose measurement is ``transform`` of the prediction, and the prediction."""
    record = synthetic_record()
    truth = (
        dict(record.predicted) if transform is None else {**record.predicted, **transform(record)}
    )
    rng = np.random.default_rng(seed)
    train, held_out, segments = windows()
    measured = {}
    for key in OUTPUT_CHANNELS:
        swing = float(np.ptp(truth[key][record.time > SEGMENT_START]))
        measured[key] = truth[key] + NOISE * swing * rng.standard_normal(record.time.size)
    dataset = Dataset(
        name="synthetic",
        time=record.time,
        pressure=record.pressure,
        measured=measured,
        train=train,
        held_out=held_out,
        segments=segments,
        period=PERIOD,
        sample_time=SAMPLE_TIME,
    )
    predictions = {
        w: np.array([record.predicted[key][dataset.mask((w,))] for key in OUTPUT_CHANNELS])
        for w in (*train, *held_out)
    }
    return dataset, predictions


def describe(transform: Transform | None, seed: int = 0) -> ResidualDescription:
    dataset, predictions = make_case(transform, seed)
    return describe_residual(dataset, predictions, noise_cost=dataset.noise_cost())


# --- the forms, made independently of the module ------------------------------------------------


def static_map(record: Record) -> dict[str, FloatArray]:
    force = record.predicted["F_k"]  # a load cell read through v (1 + 0.3 v / 8.9 kN)
    return {"F_k": force * (1.0 + 0.3 * force / 8.9e3)}


def backlash(record: Record) -> dict[str, FloatArray]:
    x = record.predicted["x_c"]
    half = 0.5 * 8e-6  # m: a play of 8 um
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, x.size):
        y[k] = min(max(y[k - 1], x[k] - half), x[k] + half)
    return {"x_c": y}


def level_gain(record: Record) -> dict[str, FloatArray]:
    gain = 1.0 + 0.1 * (record.level - LEVELS[0]) / 1e6  # +10 % per MPa of mean pressure
    return {"x_c": gain * record.predicted["x_c"]}


def fluid_loss(record: Record) -> dict[str, FloatArray]:
    bore = record.predicted["p_b"]
    volume = np.concatenate([[0.0], np.cumsum(0.5 * (bore[1:] + bore[:-1]) * SAMPLE_TIME)])
    return {"F_k": record.predicted["F_k"] - 1.5e-5 * volume}  # N per Pa s


def extra_lag(record: Record) -> dict[str, FloatArray]:
    lag = scipy.signal.lti([1.0], [6e-3, 1.0])  # 6 ms
    return {"p_b": scipy.signal.lsim(lag, record.predicted["p_b"], record.time)[1]}


def resonance(record: Record) -> dict[str, FloatArray]:
    omega, zeta = 2 * np.pi * 35.0, 0.05
    mode = scipy.signal.lti([-1.0, 0.0, 0.0], [1.0, 2 * zeta * omega, omega**2])
    force = record.predicted["F_k"]
    return {"F_k": force + scipy.signal.lsim(mode, force - force[0], record.time)[1]}


MADE_BY = {
    "static_map": (static_map, "F_k"),
    "backlash": (backlash, "x_c"),
    "level_gain": (level_gain, "x_c"),
    "fluid_loss": (fluid_loss, "F_k"),
    "extra_lag": (extra_lag, "p_b"),
    "resonance": (resonance, "F_k"),
}


def test_every_form_has_a_synthetic_case() -> None:
    assert set(MADE_BY) == {form.name for form in FORMS}


@pytest.mark.parametrize("form", sorted(MADE_BY))
def test_the_form_that_made_the_misfit_is_ranked_first_and_cuts_the_error_three_times(
    form: str,
) -> None:
    transform, channel = MADE_BY[form]
    description = describe(transform)
    best = description.best
    assert best is not None, description.summary
    assert (best.form, best.channel) == (form, channel), [
        (f.form, f.channel, round(f.improvement, 2)) for f in description.forms[:4]
    ]
    assert best.improvement > 3.0
    assert description.channel == channel
    assert description.shares[channel] > 0.9
    assert description.summary.startswith("unexplained; looks like")
    assert f"of {channel}" in description.summary
    # beside a verdict that names an effect, the same description is the baseline's misfit
    head = "the baseline's misfit"
    baseline = description.reworded(head)
    assert baseline.summary == description.summary.replace("unexplained", head, 1)
    assert baseline.forms == description.forms and baseline.best == description.best
    assert description.verdict_entry() == {
        "description": best.description,
        "form": form,
        "channel": channel,
        "improvement": round(best.improvement, 3),
    }


def test_fitted_parameters_come_back_in_si_units() -> None:
    by_form = {(f.form, f.channel): f for f in describe(extra_lag).forms}
    lag = {p.name: p for p in by_form[("extra_lag", "p_b")].parameters}
    assert lag["time_constant"].unit == "s"
    assert lag["time_constant"].value == pytest.approx(6e-3, rel=0.1)
    by_form = {(f.form, f.channel): f for f in describe(resonance).forms}
    mode = {p.name: p for p in by_form[("resonance", "F_k")].parameters}
    assert mode["frequency"].value == pytest.approx(35.0, rel=0.05)
    assert mode["frequency"].unit == "Hz"
    by_form = {(f.form, f.channel): f for f in describe(static_map).forms}
    cubic = {p.name: p for p in by_form[("static_map", "F_k")].parameters}
    assert cubic["quadratic"].unit == "1/N"
    assert cubic["quadratic"].value == pytest.approx(0.3 / 8.9e3, rel=0.1)
    by_form = {(f.form, f.channel): f for f in describe(backlash).forms}
    width = {p.name: p for p in by_form[("backlash", "x_c")].parameters}["width"]
    assert width.value == pytest.approx(8e-6, rel=0.1)
    assert width.unit == "m"


@pytest.mark.parametrize("seed", [1, 2])
def test_pure_noise_has_no_form_that_stands_out(seed: int) -> None:
    description = describe(None, seed)
    assert description.best is None
    assert max(f.improvement for f in description.forms) < 1.5
    assert "nothing stands out" in description.summary
    assert description.verdict_entry() is None
    assert not description.grows_with_pressure
    assert not description.drifts


def test_a_static_map_is_static_symmetric_and_grows_with_pressure() -> None:
    description = describe(static_map)
    assert description.static and not description.dynamic
    assert description.symmetric
    assert description.grows_with_pressure
    assert not description.drifts
    assert "static, growing with pressure, symmetric" in description.summary


def test_a_lag_is_rate_dependent_symmetric_and_the_same_at_every_level() -> None:
    description = describe(extra_lag)
    assert description.dynamic and not description.static
    assert description.symmetric
    assert not description.level_dependent
    assert not description.grows_with_pressure


def test_backlash_is_rate_dependent_and_symmetric() -> None:
    description = describe(backlash)
    assert description.dynamic and not description.static
    assert description.symmetric


def test_a_gain_that_rises_with_the_level_grows_with_pressure() -> None:
    assert describe(level_gain).grows_with_pressure


def test_a_gain_that_falls_with_the_level_does_not_grow_with_pressure() -> None:
    def falling(record: Record) -> dict[str, FloatArray]:
        return {"x_c": (1.0 - 0.1 * (record.level - LEVELS[0]) / 1e6) * record.predicted["x_c"]}

    description = describe(falling)
    assert description.level_dependent and not description.grows_with_pressure
    assert "falling with pressure" in description.summary


def test_a_misfit_on_release_only_is_asymmetric() -> None:
    def release_gain(record: Record) -> dict[str, FloatArray]:
        force = record.predicted["F_k"]
        falling = np.gradient(force) < 0
        swing = force - np.convolve(force, np.ones(100) / 100, mode="same")  # about the cycle mean
        return {"F_k": force + 0.05 * swing * falling}

    description = describe(release_gain)
    assert not description.symmetric
    assert description.misfit().asymmetry < 0
    assert "asymmetric (larger on release)" in description.summary


def test_fluid_loss_drifts() -> None:
    description = describe(fluid_loss)
    assert description.drifts
    assert "drifting" in description.summary


def test_the_description_is_plain_json() -> None:
    document: Any = describe(static_map).as_dict()
    assert json.loads(json.dumps(document)) == document
    assert document["flags"]["static"] is True
    assert document["best"]["units"]["cubic"] == "1/N^2"


def test_a_window_without_a_prediction_is_refused() -> None:
    dataset, predictions = make_case(None)
    del predictions[dataset.held_out[0]]
    with pytest.raises(ValueError, match="no baseline prediction"):
        describe_residual(dataset, predictions)
    dataset, predictions = make_case(None)
    predictions[dataset.train[0]] = predictions[dataset.train[0]][:, 1:]
    with pytest.raises(ValueError, match="should be"):
        describe_residual(dataset, predictions)


def test_play_operator_follows_its_definition() -> None:
    signal = np.sin(np.linspace(0, 6 * np.pi, 400)) + 0.01 * np.cos(np.linspace(0, 90, 400))
    expected = np.empty_like(signal)
    expected[0] = signal[0]
    for k in range(1, signal.size):
        expected[k] = min(max(expected[k - 1], signal[k] - 0.2), signal[k] + 0.2)
    np.testing.assert_allclose(play(signal, 0.4), expected)


def test_a_transducer_whose_gain_changes_with_its_reading_looks_like_a_static_map_of_F_k() -> None:
    truth = dataclasses.replace(
        nominal_rigs()["one_washer_open"],
        caliper_stiffness=4.0e7 * 1.05,
        needle_valve_resistance=3.2e10 * 0.9,
    )
    nominal = nominal_rigs()["one_washer_open"]
    run = simulate_rig(
        truth,
        [make_effect("sensor_nonlinearity", 1.0)],
        seed_pulsing(SEED_MAX_PRESSURES, pulsing_s=5.0),
        seed=4,
    )
    dataset = prepare(run.as_recording(), nominal)
    calibration = calibrate(dataset, nominal)
    baseline_model = Model(calibration, [], dataset)
    baseline = fit(baseline_model)
    predictions = baseline_predictions(baseline_model, baseline.theta)
    description = describe_residual(dataset, predictions, noise_cost=dataset.noise_cost())
    best = description.best
    assert best is not None, description.summary
    assert best.form in ("static_map", "level_gain"), description.summary
    assert best.channel == "F_k"
    assert best.improvement > 3.0
    assert description.channel == "F_k"
    assert description.static
    assert description.grows_with_pressure
