"""Fit candidate models on the training windows and score them on the held-out windows.

Each window is simulated from ``PREROLL`` seconds before it, starting at equilibrium, so the
start-up transient has died away inside the window (the LTI model's slowest mode decays in
about 0.1 s; a slider settles within one cycle), or from longer before when a candidate's
memory forgets its start more slowly (``Candidate.lead_in``: a seal seat that creeps over a
second). Training windows are capped at ``FIT_SPAN`` seconds, which keeps a fit to a few
seconds; held-out windows are scored whole. Windows that do not repeat (a sweep, a ramp:
``Window.capped`` false) enter a fit whole, from their ``lead_in``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from brake_hil.diagnosis.calibration import (
    MODEL_ERROR,
    Calibration,
    apply_multipliers,
    prior_residual,
)
from brake_hil.diagnosis.candidates.base import (
    Candidate,
    Context,
    Draft,
    own_columns,
    rig_context,
)
from brake_hil.diagnosis.dataset import Dataset, Window, read_as_measured, read_where_held
from brake_hil.diagnosis.engine import ModelSpec, simulate_batch
from brake_hil.errors import FitError
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import BoolArray, FloatArray, IndexArray

NOT_FINITE_RESIDUAL = 1.0e6
"""What a residual the simulation could not give (not finite) counts as: far above any real
one (a misfit of ``MODEL_ERROR`` counts 1), so the solver steps back from where the model goes
unstable instead of stopping on it."""
PREROLL = 0.8
"""Seconds simulated before a window (s), at least."""
FIT_SPAN = 1.6
"""Longest stretch of a training window used in a fit (s): eight 5 Hz cycles."""
FIT_DECIMATION = 2
"""Every n-th sample of a window enters the fit's residuals."""
PRIOR_SPAN = 3.0
"""Calibration multipliers may move this many prior sigmas in a candidate's fit."""
RESTART_SIGMAS = 1.0
"""A calibration that moved a value more than this many prior sigmas may have taken a single's
physics in its place (``x_c`` acquired late: the caliper's stiffness and force area both
lowered, to lag it), and a fit started there can stay near it: each single is then also fitted
from the rig file's values (:func:`fit_from_both`), and the better training fit kept."""


@dataclass(frozen=True)
class Fit:
    """A candidate set fitted to the training windows and scored on the held-out ones."""

    effects: tuple[str, ...]
    theta: FloatArray  # fitted parameters, natural units, concatenated over effects
    parameter_names: tuple[str, ...]
    parameter_units: tuple[str, ...]
    train_cost: float  # mean squared normalised residual, training windows
    held_out_cost: float  # the same on the held-out windows
    held_out_rms: dict[str, float]  # per channel, held-out windows, over the channel's ptp
    uncertainty: FloatArray | None = None  # one sigma of theta, natural units
    window_costs: tuple[float, ...] = ()  # held_out_cost of each held-out window alone

    def parameters(self) -> dict[str, float]:
        """Fitted parameters by name."""
        return dict(zip(self.parameter_names, self.theta.tolist()))

    def uncertainties(self) -> dict[str, float]:
        """One-sigma uncertainty of each fitted parameter (natural units, linearised)."""
        if self.uncertainty is None:
            return {}
        return dict(zip(self.parameter_names, self.uncertainty.tolist()))


class Model:
    """A set of candidates on top of a calibration, simulated over dataset windows."""

    def __init__(
        self, calibration: Calibration, candidates: Sequence[Candidate], dataset: Dataset
    ) -> None:
        self.calibration = calibration
        self.candidates = tuple(candidates)
        self.dataset = dataset
        self.context = make_context(calibration, dataset)
        self.sizes = [len(c.parameters) for c in self.candidates]
        self.preroll = max([PREROLL, *(c.lead_in for c in self.candidates)])
        self.lookahead = max([0.0, *(c.lookahead for c in self.candidates)])
        self.pressure_ceiling = 1.2 * float(np.max(dataset.pressure))

    @property
    def names(self) -> tuple[str, ...]:
        """Effect names."""
        return tuple(c.name for c in self.candidates)

    @property
    def effect_size(self) -> int:
        """Number of the candidates' own parameters (theta's leading columns)."""
        return sum(self.sizes)

    def parameters(self) -> list[tuple[str, str, float, float, bool]]:
        """``(name, unit, low, high, logarithmic)`` of every parameter, in theta order.

        The candidates' parameters come first, then the calibration's multipliers, which are
        re-fitted with every candidate under the same prior (a candidate must not be credited
        with what a parameter within its tolerance explains).
        """
        own = [
            (p.name, p.unit, p.low, p.high, p.logarithmic)
            for c in self.candidates
            for p in c.parameters
        ]
        sigmas = self.calibration.sigmas
        multipliers = [
            (
                f"calibration.{name}",
                "x",
                float(np.exp(-PRIOR_SPAN * sigma)),
                float(np.exp(PRIOR_SPAN * sigma)),
                True,
            )
            for name, sigma in sigmas.items()
        ]
        return own + multipliers

    def prior_sigmas(self) -> FloatArray:
        """Log-sigma of each multiplier column (after the candidates' own columns)."""
        return np.array(list(self.calibration.sigmas.values()))

    def start(self) -> FloatArray:
        """Start parameters: candidates' own, then the calibrated multipliers."""
        parts = [c.start(self.context) for c in self.candidates]
        parts.append(np.array(list(self.calibration.multipliers.values())))
        return np.concatenate(parts)

    def spec(self, window: Window | Sequence[Window], theta: FloatArray) -> ModelSpec:
        """The simulator spec of every row of ``theta`` (B, P) for one window.

        For several windows: ``W * B`` sets, window by window (each window's operating
        pressure sets its LTI coefficients).
        """
        windows = [window] if isinstance(window, Window) else list(window)
        names = list(self.calibration.sigmas)
        rig = self.calibration.rig
        draft = Draft(
            [
                apply_multipliers(rig, w.mean_pressure, dict(zip(names, row)))
                for w in windows
                for row in theta[:, self.effect_size :]
            ]
        )
        rows = np.tile(theta, (len(windows), 1))
        for candidate, own in own_columns(self.candidates, rows):
            candidate.fill(draft, own, self.context)
        return draft.spec()

    def _span(self, window: Window, span: float | None) -> tuple[int, int, BoolArray]:
        """First and end sample simulated for ``window``, and the mask of those inside it.

        The simulation starts ``preroll`` seconds before the window (its ``lead_in`` when
        longer) and ends ``lookahead`` seconds after it (or at the recording's end). ``span``
        caps only a ``capped`` window (steady pulsing: its cycles repeat).
        """
        ds = self.dataset
        capped = span is not None and window.capped
        end = min(window.end, window.start + span) if capped and span else window.end
        first = int(np.searchsorted(ds.time, window.start - max(self.preroll, window.lead_in)))
        last = int(np.searchsorted(ds.time, end + self.lookahead - 1e-9))
        time = ds.time[first:last]
        inside = (time >= window.start - 1e-9) & (time < end - 1e-9)
        return first, last, inside

    def simulate_windows(
        self, windows: Sequence[Window], theta: FloatArray, span: float | None = None
    ) -> list[tuple[FloatArray, IndexArray]]:
        """:meth:`simulate` of every window, run as one batch (one step serves them all).

        Windows shorter than the longest are driven on with their last input sample past
        their end; a causal model's outputs inside a window do not depend on what follows.
        """
        ds = self.dataset
        spans = [self._span(w, span) for w in windows]
        length = max(last - first for first, last, _ in spans)
        batch = theta.shape[0]
        pressure = np.empty((len(windows) * batch, length))
        starts = np.empty(len(windows) * batch)
        for k, (first, last, _) in enumerate(spans):
            rows = slice(k * batch, (k + 1) * batch)
            pressure[rows, : last - first] = ds.pressure[first:last]
            pressure[rows, last - first :] = ds.pressure[last - 1]
            starts[rows] = ds.time[first]
        outputs = simulate_batch(
            self.spec(windows, theta),
            pressure,
            ds.sample_time,
            start_time=starts,
            pressure_ceiling=self.pressure_ceiling,
        )
        if ds.held:
            outputs = read_where_held(outputs, ds.held, 1.0 / ds.sample_time)
        result = []
        for k, (first, last, inside) in enumerate(spans):
            part = outputs[k * batch : (k + 1) * batch, :, : last - first]
            index = np.arange(first, last)[inside]
            result.append((self._as_read(windows[k], part[:, :, inside], index), index))
        return result

    def _as_read(self, window: Window, outputs: FloatArray, index: IndexArray) -> FloatArray:
        """``outputs`` (B, 3, n) as the transducers read them (:func:`read_as_measured`)."""
        measured = self.dataset.measured
        return np.stack(
            [
                read_as_measured(outputs[:, c], measured[key][index], window, key)
                for c, key in enumerate(OUTPUT_CHANNELS)
            ],
            axis=1,
        )

    def simulate(
        self, window: Window, theta: FloatArray, span: float | None = None
    ) -> tuple[FloatArray, IndexArray]:
        """Outputs (B, 3, n) over a window (or its first ``span`` s) and its sample indices."""
        ds = self.dataset
        first, last, inside = self._span(window, span)
        outputs = simulate_batch(
            self.spec(window, theta),
            ds.pressure[first:last],
            ds.sample_time,
            start_time=float(ds.time[first]),
            pressure_ceiling=self.pressure_ceiling,
        )
        if ds.held:
            outputs = read_where_held(outputs, ds.held, 1.0 / ds.sample_time)
        index = np.arange(first, last)[inside]
        return self._as_read(window, outputs[:, :, inside], index), index

    def residuals(
        self,
        windows: Sequence[Window],
        theta: FloatArray,
        span: float | None = None,
        decimation: int = 1,
    ) -> FloatArray:
        """Normalised residuals (B, samples) of each row of ``theta`` over ``windows``."""
        scale = self.dataset.scale()
        parts = []
        for outputs, index in self.simulate_windows(windows, theta, span):
            for channel, key in enumerate(OUTPUT_CHANNELS):
                measured = self.dataset.measured[key][index]
                parts.append(
                    ((outputs[:, channel] - measured[None, :]) / scale[key])[:, ::decimation]
                )
        return np.concatenate(parts, axis=1)

    def scores(
        self, windows: Sequence[Window], theta: FloatArray
    ) -> tuple[dict[str, float], tuple[float, ...]]:
        """RMS per channel over ``windows``, and each window's cost alone.

        Each channel's RMS residual over its peak-to-peak in the whole dataset (the fits'
        scale, not the paper's per-window NRMSE). A window's cost is the mean over channels
        of its squared RMS (the measure ``Fit.held_out_cost`` takes over all held-out
        windows).
        """
        scale = self.dataset.scale()
        errors: dict[str, list[FloatArray]] = {key: [] for key in OUTPUT_CHANNELS}
        window_costs = []
        for outputs, index in self.simulate_windows(windows, theta[None, :]):
            costs = []
            for channel, key in enumerate(OUTPUT_CHANNELS):
                residual = (outputs[0, channel] - self.dataset.measured[key][index]) / scale[key]
                errors[key].append(residual)
                costs.append(float(np.mean(residual**2)))
            window_costs.append(float(np.mean(costs)))
        nrmse = {key: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for key, v in errors.items()}
        return nrmse, tuple(window_costs)


def make_context(calibration: Calibration, dataset: Dataset) -> Context:
    """What candidates may know: the rig's derived seal and volumes, the model's flow."""
    rig = calibration.rig
    window = dataset.segments[len(dataset.segments) // 2]
    params = calibration.parameters(window.mean_pressure)
    bore_amplitude = 0.5 * float(np.ptp(dataset.measured["p_b"][dataset.mask((window,))]))
    # Fluid volume taken per pascal: the chamber's compliance and the caliper's give (eq. 21d
    # with the quasi-static caliper of eq. 21f).
    volume_per_pascal = params.bore_compliance + params.piston_area * params.bore_area / (
        params.caliper_stiffness + params.effective_hydraulic_stiffness
    )
    flow = max(2 * np.pi * rig.excitation_hz * volume_per_pascal * bore_amplitude, 1e-9)
    return rig_context(
        rig,
        flow_amplitude=flow,
        time_reference=float(np.mean([0.5 * (w.start + w.end) for w in dataset.train])),
        last_time=float(max(w.end for w in (*dataset.train, *dataset.held_out))),
    )


def _to_search(model: Model, theta: FloatArray) -> FloatArray:
    return np.array([np.log(v) if log else v for v, (*_, log) in zip(theta, model.parameters())])


def _from_search(model: Model, x: FloatArray) -> FloatArray:
    return np.array([np.exp(v) if log else v for v, (*_, log) in zip(x, model.parameters())])


def fit(model: Model, start: FloatArray | None = None, max_iterations: int = 15) -> Fit:
    """Bounded least squares on the training windows; score on the held-out windows.

    The objective is the calibration's: data residuals over ``MODEL_ERROR`` plus the prior
    on the calibration multipliers. The Jacobian's columns are simulated in one batch with
    the point itself. A ``start`` at which the simulation is not finite (two effects' fitted
    values can make an explicit term unstable together) falls back to the model's own start.

    Where the simulation goes non-finite during the search (a step of the Jacobian's, from the
    start on, or a trial point) its residuals count ``NOT_FINITE_RESIDUAL`` each.

    Raises:
        FitError: the simulation is not finite at the model's own start either, or the
            solver fails on it.
    """
    name = " + ".join(model.names) or "the LTI baseline"
    search = _Search(model)
    x0 = search.clipped(model.start() if start is None else start)
    with np.errstate(over="ignore", invalid="ignore"):  # non-finite is handled here
        if not np.all(np.isfinite(search.evaluate(x0)[0])) and start is not None:
            x0 = search.clipped(model.start())  # the model's own start
        if not np.all(np.isfinite(search.evaluate(x0)[0])):
            raise FitError(f"{name}: the model's simulation is not finite where its fit starts")
        try:
            result = scipy.optimize.least_squares(
                search.residual,
                x0,
                jac=search.jacobian,
                bounds=(search.lower, search.upper),
                method="trf",
                max_nfev=max_iterations,
                x_scale=search.width / 4,
            )
        except (ValueError, np.linalg.LinAlgError) as error:
            raise FitError(f"{name}: the fit failed: {error}") from error
    return _scored(model, name, result, search.whiten.shape[0])


def fit_from_both(model: Model) -> Fit:
    """``fit(model)`` from the calibrated values, and from the rig file's too when needed.

    The second start is taken when the calibration moved a value more than
    ``RESTART_SIGMAS`` prior sigmas; a single's other starts (``Candidate.other_starts``)
    are tried from the calibrated values. The best training fit is kept.

    Raises:
        FitError: as :func:`fit`, from the calibrated start.
    """
    fitted = fit(model)
    starts = []
    if len(model.candidates) == 1:
        for own in model.candidates[0].other_starts(model.context):
            start = model.start()
            start[: model.effect_size] = own
            starts.append(start)
    moved = model.calibration.prior_z()
    if moved and max(abs(z) for z in moved.values()) > RESTART_SIGMAS:
        start = model.start()
        start[model.effect_size :] = 1.0
        starts.append(start)
    for start in starts:
        try:
            again = fit(model, start=start)
        except FitError:
            continue
        fitted = again if again.train_cost < fitted.train_cost else fitted
    return fitted


class _Search:
    """The fit's problem in the search space (logarithms where a parameter is logarithmic).

    Residuals and their forward-difference Jacobian come from one batch simulation of the
    point and its steps, cached for the point last asked.
    """

    def __init__(self, model: Model) -> None:
        specs = model.parameters()
        self.model = model
        self.own = model.effect_size
        self.whiten = model.calibration.whitening()  # the multipliers' correlated prior
        self.lower = np.array([np.log(lo) if log else lo for _, _, lo, _, log in specs])
        self.upper = np.array([np.log(hi) if log else hi for _, _, _, hi, log in specs])
        self.width = self.upper - self.lower
        self.steps = 1e-3 * np.maximum(self.width, 1e-6)
        self._cache: dict[bytes, FloatArray] = {}

    def clipped(self, theta: FloatArray) -> FloatArray:
        """``theta`` (natural units) in the search space, within the bounds."""
        return np.clip(_to_search(self.model, theta), self.lower, self.upper)

    def rows(self, x: FloatArray) -> FloatArray:
        """The point and its step along every parameter."""
        points = [x] + [_step(x, j, self.steps[j], self.upper) for j in range(x.size)]
        return np.array(points)

    def objective(self, points: FloatArray) -> FloatArray:
        """Scaled data residuals and the multipliers' prior, one row per point."""
        model = self.model
        thetas = np.array([_from_search(model, r) for r in points])
        data = model.residuals(model.dataset.train, thetas, FIT_SPAN, FIT_DECIMATION)
        data = data / (MODEL_ERROR * np.sqrt(data.shape[1]))
        return np.hstack([data, prior_residual(points[:, self.own :] @ self.whiten.T)])

    def evaluate(self, x: FloatArray) -> FloatArray:
        """:meth:`objective` of :meth:`rows` of ``x``, cached."""
        key = x.tobytes()
        if key not in self._cache:
            self._cache.clear()
            self._cache[key] = self.objective(self.rows(x))
        return self._cache[key]

    def searched(self, x: FloatArray) -> FloatArray:
        """:meth:`evaluate`, a value that is not finite counting ``NOT_FINITE_RESIDUAL``."""
        values = self.evaluate(x)
        return np.where(np.isfinite(values), values, NOT_FINITE_RESIDUAL)

    def residual(self, x: FloatArray) -> FloatArray:
        """The residuals at ``x``."""
        return np.asarray(self.searched(x)[0], dtype=float)

    def jacobian(self, x: FloatArray) -> FloatArray:
        """Forward differences of the residuals at ``x``."""
        r = self.searched(x)
        upper, steps = self.upper, self.steps
        actual = np.array([_step(x, j, steps[j], upper)[j] - x[j] for j in range(x.size)])
        return np.asarray((r[1:] - r[0]).T / actual, dtype=float)


def _scored(model: Model, name: str, result: scipy.optimize.OptimizeResult, priors: int) -> Fit:
    """The solver's ``result`` as a :class:`Fit`, scored on the held-out windows.

    ``priors``: the prior residuals at the end of ``result.fun`` (one per multiplier).

    Raises:
        FitError: the fitted model's simulation is not finite on the held-out windows.
    """
    specs = model.parameters()
    theta = _from_search(model, result.x)
    data_part = result.fun[: result.fun.size - priors] * MODEL_ERROR
    train_cost = float(np.sum(data_part**2))
    uncertainty = _uncertainty(model, result.jac, theta, train_cost, data_part.size)
    with np.errstate(over="ignore", invalid="ignore"):
        nrmse, window_costs = model.scores(model.dataset.held_out, theta)
    if not all(np.isfinite(v) for v in (*nrmse.values(), *window_costs)):
        raise FitError(f"{name}: the fitted model's simulation is not finite on held-out data")
    return Fit(
        effects=model.names,
        theta=theta,
        parameter_names=tuple(name for name, *_ in specs),
        parameter_units=tuple(unit for _, unit, *_ in specs),
        train_cost=train_cost,
        held_out_cost=float(np.mean([v**2 for v in nrmse.values()])),
        held_out_rms=nrmse,
        uncertainty=uncertainty,
        window_costs=window_costs,
    )


def _step(x: FloatArray, j: int, size: float, upper: FloatArray) -> FloatArray:
    """``x`` moved by ``size`` along ``j``, backwards where the upper bound is in the way."""
    moved = x.copy()
    moved[j] = x[j] + size if x[j] + size <= upper[j] else x[j] - size
    return moved


INDEPENDENT_SAMPLES_PER_SECOND = 60.0
"""Independent samples per second and channel of a 30 Hz low-passed signal (Nyquist)."""
RANGE_SIGMA_SHARE = 12.0**-0.5
"""A candidate's own parameter is no more uncertain than a uniform draw over its search range
(0.29 of the range, in the search's units): the fit's information adds to that, so a value
the recording does not identify (a slider beside no friction) keeps its range's sigma and
does not spread its null direction onto the values it does identify."""


def _uncertainty(
    model: Model, jac: FloatArray, theta: FloatArray, cost: float, samples: int
) -> FloatArray | None:
    """Linearised one-sigma uncertainty of ``theta`` from the fit's Jacobian.

    The Jacobian is of residuals scaled by ``MODEL_ERROR``; the misfit actually left is
    ``cost`` (mean squared), and the residual samples are correlated (30 Hz low-pass), so
    the count that sets the covariance is the independent one, about 60 per second and
    channel. The candidates' own parameters are bounded by their search range
    (``RANGE_SIGMA_SHARE``).
    """
    span = sum(min(w.end - w.start, FIT_SPAN if w.capped else np.inf) for w in model.dataset.train)
    independent = max(INDEPENDENT_SAMPLES_PER_SECOND * span * len(OUTPUT_CHANNELS), 2.0)
    inflation = max(cost / MODEL_ERROR**2, 1e-6) * max(samples / independent, 1.0)
    specs = model.parameters()[: model.effect_size]
    width = np.array([np.log(hi / lo) if log else hi - lo for _, _, lo, hi, log in specs])
    bounded = np.zeros(jac.shape[1])
    bounded[: width.size] = inflation / (RANGE_SIGMA_SHARE * np.maximum(width, 1e-300)) ** 2
    try:
        with np.errstate(over="ignore", invalid="ignore"):  # a Jacobian of NOT_FINITE_RESIDUAL
            covariance = np.linalg.inv(jac.T @ jac + np.diag(bounded)) * inflation
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(covariance)):
        return None
    sigma = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    logarithmic = np.array([log for *_, log in model.parameters()], dtype=bool)
    return np.asarray(np.where(logarithmic, theta * sigma, sigma), dtype=float)
