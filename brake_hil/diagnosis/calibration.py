"""Calibrate the LTI baseline to a recording, within the rig file's tolerances.

The rig file is nominal; the seed identifies its uncertain parameters from data. Here the
uncertain ones are fitted by least squares on the training windows, each as a log-multiplier
of its nominal value with a Gaussian prior of the rig's one-sigma tolerance (docs/interface.md):
caliper stiffness ``k_c``, needle-valve resistance ``R_v``, the seal's ``k_eh`` and ``c_eh``,
the fluid's air fraction (eq. 18: it sets ``C_b`` and ``C_i`` at every pressure, so an
error in it changes the compliance more at low pressure than at high, which one multiplier of
``C_b`` cannot follow; a rig file that overrides ``C_b`` gets a ``C_b`` multiplier instead),
and the hose wall's Young's modulus (its swelling is the part of ``C_b`` that does not change
with pressure; left out, a 10 % error in it was named hose_compliance on null recordings).
So a parameter error is not mistaken for missing physics, and a mismatch that would need a
value far outside its tolerance is left for the candidates to explain.

The data term is the mean squared residual of each channel over its peak-to-peak, divided by
``MODEL_ERROR**2``: a 0.03 % misfit on one channel weighs as much as one sigma of one parameter.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import scipy.optimize

from brake_hil.diagnosis.dataset import Dataset, Window
from brake_hil.diagnosis.engine import ModelSpec, simulate_batch
from brake_hil.physics.parameters import ModelParameters, derive_parameters
from brake_hil.physics.rig import Rig
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray

MODEL_ERROR = 0.0003
"""Relative misfit (of peak-to-peak) that weighs as one sigma of prior. The calibrated LTI
model of a virtual rig with parameter errors only fits to 0.02-0.03 % NRMSE, twice its noise;
at 0.3 % the priors held weakly identified values (``c_eh``, the air fraction) off their
truth and left a 0.1 % misfit that candidates then explained."""


@dataclass(frozen=True)
class Uncertain:
    """One calibrated coefficient: its key in the rig's tolerances and its prior sigma."""

    name: str  # ModelParameters field, or "valve_resistance"
    tolerance_key: str
    minimum_sigma: float  # floor on the log-sigma (the seed's own spread of k_eh, c_eh)


UNCERTAIN = (
    Uncertain("caliper_stiffness", "caliper.stiffness", 0.0),
    Uncertain("valve_resistance", "needle_valve.resistance", 0.0),
    Uncertain("effective_hydraulic_stiffness", "seal.shear_length", 0.5),
    Uncertain("effective_hydraulic_damping", "seal.loss_factor", 0.5),
    Uncertain("air_fraction", "fluid.air_fraction", 0.3),
    Uncertain("hose_stiffness", "hose.youngs_modulus", 0.0),
)
BORE_COMPLIANCE = Uncertain("bore_compliance", "fluid.air_fraction", 0.3)
"""Replaces ``air_fraction`` when the rig file overrides ``C_b``."""
RIG_VALUES = ("valve_resistance", "air_fraction", "hose_stiffness")
"""Multipliers of rig values (the rest multiply ModelParameters fields)."""


def uncertain_values(rig: Rig) -> tuple[Uncertain, ...]:
    """The calibrated values of a rig file.

    A value whose tolerance the rig file sets to 0 is held fixed at its nominal value
    (docs/interface.md: tolerance 0 means known exactly): it is left out of the calibration and
    of every candidate's fit.
    """
    values: tuple[Uncertain, ...] = UNCERTAIN
    if "C_b" in rig.model_overrides:
        values = tuple(BORE_COMPLIANCE if u.name == "air_fraction" else u for u in UNCERTAIN)
    return tuple(u for u in values if rig.tolerance(u.tolerance_key) > 0.0)


@dataclass(frozen=True)
class Calibration:
    """The calibrated LTI baseline."""

    rig: Rig
    multipliers: dict[str, float]  # per uncertain coefficient, fitted / nominal
    sigmas: dict[str, float]  # log-sigma of each multiplier (prior)
    uncertainty: dict[str, float]  # posterior log-sigma (from the Jacobian)
    cost: float  # data + prior cost at the optimum

    def parameters(self, mean_pressure: float) -> ModelParameters:
        """Calibrated LTI coefficients at a mean master-cylinder pressure (Pa)."""
        return apply_multipliers(self.rig, mean_pressure, self.multipliers)

    def prior_z(self) -> dict[str, float]:
        """How many prior sigmas each multiplier moved (evidence when large)."""
        return {k: float(np.log(v) / self.sigmas[k]) for k, v in self.multipliers.items()}


def apply_multipliers(rig: Rig, mean_pressure: float, m: dict[str, float]) -> ModelParameters:
    """Nominal coefficients at ``mean_pressure`` (Pa) with the multipliers ``m`` applied."""
    if "air_fraction" in m:
        fluid = replace(rig.fluid, air_fraction=rig.fluid.air_fraction * m["air_fraction"])
        rig = replace(rig, fluid=fluid)
    if "hose_stiffness" in m:
        hose = replace(rig.hose, youngs_modulus=rig.hose.youngs_modulus * m["hose_stiffness"])
        rig = replace(rig, hose=hose)
    nominal = derive_parameters(rig, mean_pressure)
    changes = {
        name: getattr(nominal, name) * value for name, value in m.items() if name not in RIG_VALUES
    }
    if "valve_resistance" in m:
        valve = rig.model_overrides.get("R_v", rig.needle_valve_resistance)
        changes["line_resistance"] = nominal.line_resistance + valve * (m["valve_resistance"] - 1)
    return nominal.with_changes(**changes)


def window_residuals(
    dataset: Dataset,
    windows: tuple[Window, ...],
    predict: Callable[[Window], dict[str, FloatArray]],
) -> FloatArray:
    """Normalised residuals (prediction - measurement) / ptp over ``windows``, all channels."""
    scale = dataset.scale()
    parts = []
    for window in windows:
        inside = dataset.mask((window,))
        predicted = predict(window)
        for key in OUTPUT_CHANNELS:
            parts.append((predicted[key][inside] - dataset.measured[key][inside]) / scale[key])
    return np.concatenate(parts)


def simulate_lti(dataset: Dataset, params: ModelParameters) -> dict[str, FloatArray]:
    """The LTI model's outputs on the dataset's input."""
    outputs = simulate_batch(ModelSpec((params,)), dataset.pressure, dataset.sample_time)[0]
    return dict(zip(OUTPUT_CHANNELS, outputs))


def calibrate(dataset: Dataset, rig: Rig) -> Calibration:
    """Least-squares calibration of the LTI baseline on the training windows."""
    sigmas = {
        u.name: max(rig.tolerance(u.tolerance_key), u.minimum_sigma) for u in uncertain_values(rig)
    }
    names = list(sigmas)
    if not names:  # every uncertain value held fixed (tolerance 0): the nominal model
        return Calibration(rig=rig, multipliers={}, sigmas={}, uncertainty={}, cost=0.0)
    sigma = np.array([sigmas[n] for n in names])
    samples = int(dataset.mask(dataset.train).sum()) * len(OUTPUT_CHANNELS)

    def residuals(log_m: FloatArray) -> FloatArray:
        m = dict(zip(names, np.exp(log_m)))
        cache: dict[int, dict[str, FloatArray]] = {}

        def predict(window: Window) -> dict[str, FloatArray]:
            if window.segment not in cache:
                cache[window.segment] = simulate_lti(
                    dataset, apply_multipliers(rig, window.mean_pressure, m)
                )
            return cache[window.segment]

        data = window_residuals(dataset, dataset.train, predict)
        return np.concatenate([data / (MODEL_ERROR * np.sqrt(samples)), log_m / sigma])

    fit = scipy.optimize.least_squares(
        residuals,
        np.zeros(len(names)),
        method="trf",
        x_scale=sigma,
        diff_step=1e-3,
        max_nfev=60,
    )
    jacobian = fit.jac
    try:
        covariance = np.linalg.inv(jacobian.T @ jacobian)
        posterior = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    except np.linalg.LinAlgError:
        posterior = sigma
    return Calibration(
        rig=rig,
        multipliers=dict(zip(names, np.exp(fit.x).tolist())),
        sigmas=sigmas,
        uncertainty=dict(zip(names, posterior.tolist())),
        cost=float(2.0 * fit.cost),
    )
