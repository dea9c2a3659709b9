"""Calibrate the LTI baseline to a recording, within the rig file's tolerances.

The rig file is nominal; the seed identifies its uncertain parameters from data. Here the
uncertain ones are fitted by least squares on the training windows, each as a log-multiplier
of its nominal value with a Gaussian prior of the rig's one-sigma tolerance (docs/interface.md):
caliper stiffness ``k_c``, needle-valve resistance ``R_v``, the seal's ``k_eh`` and ``c_eh``,
the fluid's air fraction (eq. 18: it sets ``C_b`` and ``C_i`` at every pressure, so an
error in it changes the compliance more at low pressure than at high, which one multiplier of
``C_b`` cannot follow; a rig file that overrides ``C_b`` gets a ``C_b`` multiplier instead),
the hose wall's Young's modulus (its swelling is the part of ``C_b`` that does not change
with pressure; left out, a 10 % error in it was named hose_compliance on null recordings),
and the caliper's force area ``A_eb`` (the share of the pressure force the caliper body sees:
the piston diameter and the bore's area ratio, 10 % each, move it by up to a fifth; left out,
that share was named ``eccentric_load`` on null recordings and beside the right effect),
and the pistons' area ``A_ep`` (the piston diameter's 10 % is a fifth of the area, and of the
pressure force ``F_k`` reads; held at the rig file's, such a rig was named stick-slip or
``unexplained``). Beyond two tolerances a multiplier's prior steepens
(``BEYOND_TOLERANCE_SLOPE``): a tolerance is one standard deviation. Every
other toleranced rig value that reaches the model (bore length, piston diameter, the
bore's area ratio, fluid bulk modulus, line geometry, viscosity ...) is carried into the prior
(:mod:`.tolerance_prior`): the prior of the multipliers is the covariance its tolerances give
them (the bore's volume widens the hose wall's and the air's priors, which together set
``C_b``). So a parameter error within tolerance is not mistaken for missing physics, and a
mismatch that would need a value far outside its tolerance is left for the candidates to
explain, or named as that value (:mod:`.rig_findings`).

The data term is the mean squared residual of each channel over its peak-to-peak, divided by
``MODEL_ERROR**2``: a 0.03 % misfit on one channel weighs as much as one sigma of one parameter.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.optimize

from brake_hil.diagnosis.dataset import Dataset, Window, read_as_measured, read_where_held
from brake_hil.diagnosis.engine import ModelSpec, simulate_batch
from brake_hil.diagnosis.tolerance_prior import KEY_FIELDS, prior_covariance
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
    Uncertain("bore_area", "bore.area_ratio", 0.0),
    Uncertain("piston_area", "pistons.diameter", 0.0),
)
BORE_COMPLIANCE = Uncertain("bore_compliance", "fluid.air_fraction", 0.3)
"""Replaces ``air_fraction`` when the rig file overrides ``C_b``."""
PROPAGATED: tuple[Uncertain, ...] = ()
"""Calibrated too when their tolerance matters to the recording (``HOLD_BELOW``): none. Freed,
the bore chamber's volume (``bore_volume``) and the line inertance stood in for the hose's
distributed compliance and for the seals' stick-slip; their rig values' tolerances are carried
into the other multipliers' prior instead (the bore length into the hose wall's and the air's,
which together set ``C_b``)."""
RIG_VALUES = ("valve_resistance", "air_fraction", "hose_stiffness", "bore_volume", "piston_area")
"""Multipliers applied by hand (the rest multiply ModelParameters fields)."""
MODEL_KEYS = {
    "caliper_stiffness": "k_c",
    "valve_resistance": "R_v",
    "effective_hydraulic_stiffness": "k_eh",
    "effective_hydraulic_damping": "c_eh",
    "bore_compliance": "C_b",
    "block_stiffness": "k_k",
    "line_inertance": "I_line",
    "bore_area": "A_eb_over_A_ep",
}
"""The ``model:`` key that overrides each calibrated quantity outright (docs/interface.md)."""
BEYOND_TOLERANCE_SLOPE = 4.0
"""Slope of a multiplier's prior residual beyond ``PRIOR_EDGE`` (sigmas per sigma).

A tolerance is one standard deviation (docs/interface.md), so a rig lies within two of them
but seldom beyond: a calibration that moves a value past that pays this many times as
steeply (three sigmas out cost as six), so several values pushed far together (larger pistons
with a stiffer seal) cannot stand in for a physics the rig file leaves out (a hose)."""
PRIOR_EDGE = 2.0
"""Prior sigmas (whitened) within which the prior is the tolerances' Gaussian: 95 % of rigs."""
HOLD_BELOW = 1.0
"""A propagated quantity whose one-sigma move changes the data cost by less than this (one
prior sigma's worth) cannot be told by the recording: it is held at the rig file's value (its
tolerance stays in the other multipliers' prior)."""


def uncertain_values(rig: Rig) -> tuple[Uncertain, ...]:
    """The calibrated values of a rig file.

    A value whose tolerance the rig file sets to 0 is held fixed at its nominal value
    (docs/interface.md: tolerance 0 means known exactly): it is left out of the calibration and
    of every candidate's fit.
    """
    overrides = rig.model_overrides
    values: tuple[Uncertain, ...] = UNCERTAIN
    if "C_b" in overrides:
        values = tuple(BORE_COMPLIANCE if u.name == "air_fraction" else u for u in UNCERTAIN)
    values = tuple(u for u in values if rig.tolerance(u.tolerance_key) > 0.0)
    extra = tuple(u for u in PROPAGATED if not (u.name == "bore_volume" and "C_b" in overrides))
    return values + extra


def propagated(name: str) -> bool:
    """Whether ``name`` is calibrated only where its tolerance matters (``PROPAGATED``)."""
    return any(u.name == name for u in PROPAGATED)


@dataclass(frozen=True)
class Calibration:
    """The calibrated LTI baseline."""

    rig: Rig
    multipliers: dict[str, float]  # per uncertain coefficient, fitted / nominal
    sigmas: dict[str, float]  # log-sigma of each multiplier (prior)
    uncertainty: dict[str, float]  # posterior log-sigma (from the Jacobian)
    cost: float  # data + prior cost at the optimum
    correlation: FloatArray | None = None  # prior correlation of the multipliers (None: none)
    setters: dict[str, tuple[str, ...]] = field(default_factory=dict)  # rig keys setting each

    def whitening(self) -> FloatArray:
        """``W`` with ``W log_m`` standard normal under the prior (``sigmas``, ``correlation``)."""
        sigma = np.array(list(self.sigmas.values()))
        if self.correlation is None or self.correlation.shape != (sigma.size, sigma.size):
            return np.diag(1.0 / sigma)
        return whitening(self.correlation * np.outer(sigma, sigma))

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
    if "bore_volume" in m:
        changes["bore_compliance"] = (
            nominal.bore_compliance * m["bore_volume"] * m.get("bore_compliance", 1.0)
        )
    if "piston_area" in m:  # the pistons' section: A_ep, and A_eb = (A_eb / A_ep) A_ep
        changes["piston_area"] = nominal.piston_area * m["piston_area"]
        changes["bore_area"] = changes.get("bore_area", nominal.bore_area) * m["piston_area"]
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
            measured = dataset.measured[key][inside]
            read = read_as_measured(predicted[key][inside], measured, window, key)
            parts.append((read - measured) / scale[key])
    return np.concatenate(parts)


def simulate_lti(dataset: Dataset, params: ModelParameters) -> dict[str, FloatArray]:
    """The LTI model's outputs on the dataset's input."""
    outputs = simulate_batch(ModelSpec((params,)), dataset.pressure, dataset.sample_time)[0]
    if dataset.held:
        outputs = read_where_held(outputs, dataset.held, 1.0 / dataset.sample_time)
    return dict(zip(OUTPUT_CHANNELS, outputs))


def prior_residual(white: FloatArray) -> FloatArray:
    """The prior's residual of whitened log-multipliers (continuous at ``PRIOR_EDGE``).

    Within ``PRIOR_EDGE`` the values themselves, ``BEYOND_TOLERANCE_SLOPE`` times as steep beyond.
    """
    size = np.abs(white)
    edge = PRIOR_EDGE
    beyond = np.sign(white) * (edge + BEYOND_TOLERANCE_SLOPE * (size - edge))
    result: FloatArray = np.where(size <= edge, white, beyond)
    return result


def whitening(covariance: FloatArray) -> FloatArray:
    """``W`` with ``W^T W`` the inverse of ``covariance`` (Cholesky; jittered if singular)."""
    scale = np.sqrt(np.diag(covariance))
    correlation = covariance / np.outer(scale, scale)
    jitter = 0.0
    while True:
        try:
            lower = np.linalg.cholesky(correlation + jitter * np.eye(len(scale)))
            break
        except np.linalg.LinAlgError:
            jitter = max(2.0 * jitter, 1e-9)
    return np.linalg.solve(lower, np.eye(len(scale))) / scale


def prior(
    rig: Rig, values: tuple[Uncertain, ...]
) -> tuple[FloatArray, dict[str, tuple[str, ...]]]:
    """The multipliers' prior covariance (tolerances propagated) and the keys setting each."""
    floors = {u.name: max(rig.tolerance(u.tolerance_key), u.minimum_sigma) for u in values}
    names = [u.name for u in values]
    own = {
        u.name: rig.tolerance(u.tolerance_key)
        for u in values
        if u.tolerance_key not in KEY_FIELDS or MODEL_KEYS.get(u.name) in rig.model_overrides
    }
    covariance, setters = prior_covariance(rig, names, apply_multipliers, floors, own)
    for u in values:
        if u.tolerance_key not in setters[u.name]:
            setters[u.name] = (u.tolerance_key, *setters[u.name])
    return covariance, setters


def calibrate(dataset: Dataset, rig: Rig) -> Calibration:
    """Least-squares calibration of the LTI baseline on the training windows."""
    samples = int(dataset.mask(dataset.train).sum()) * len(OUTPUT_CHANNELS)

    def data_term(m: dict[str, float]) -> FloatArray:
        cache: dict[int, dict[str, FloatArray]] = {}

        def predict(window: Window) -> dict[str, FloatArray]:
            if window.segment not in cache:
                cache[window.segment] = simulate_lti(
                    dataset, apply_multipliers(rig, window.mean_pressure, m)
                )
            return cache[window.segment]

        data: FloatArray = window_residuals(dataset, dataset.train, predict)
        scaled: FloatArray = data / (MODEL_ERROR * np.sqrt(samples))
        return scaled

    values = uncertain_values(rig)
    covariance, setters = prior(rig, values)
    sigma_all = np.sqrt(np.diag(covariance))
    nominal = data_term({})
    kept = tuple(
        u
        for u, s in zip(values, sigma_all)
        if not propagated(u.name)
        or (s > 0.0 and float(np.sum((data_term({u.name: float(np.exp(s))}) - nominal) ** 2)))
        >= HOLD_BELOW
    )
    if not kept:  # every uncertain value held fixed (tolerance 0): the nominal model
        return Calibration(rig=rig, multipliers={}, sigmas={}, uncertainty={}, cost=0.0)
    covariance, setters = prior(rig, kept)
    names = [u.name for u in kept]
    sigma = np.sqrt(np.diag(covariance))
    white = whitening(covariance)

    def residuals(log_m: FloatArray) -> FloatArray:
        data = data_term(dict(zip(names, np.exp(log_m))))
        return np.concatenate([data, prior_residual(white @ log_m)])

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
        posterior = np.sqrt(np.clip(np.diag(np.linalg.inv(jacobian.T @ jacobian)), 0.0, None))
    except np.linalg.LinAlgError:
        posterior = sigma
    return Calibration(
        rig=rig,
        multipliers=dict(zip(names, np.exp(fit.x).tolist())),
        sigmas=dict(zip(names, sigma.tolist())),
        uncertainty=dict(zip(names, posterior.tolist())),
        cost=float(2.0 * fit.cost),
        correlation=covariance / np.outer(sigma, sigma),
        setters=setters,
    )
