"""The diagnosis report's figures, each a PNG ``data:`` URI with a caption that holds.

Measured against baseline against improved on held-out cycles with residuals, the residual
over the phase of the 5 Hz cycle, harmonic bars (the paper's Table 1) and the seal's
hysteresis loop. A caption that claims something of a figure is checked against it: the
improved loop's caption says whether it traces the measured one, by the loop's NRMSE
(:func:`loop_nrmse`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
import math

import matplotlib

matplotlib.use("Agg")
from matplotlib.figure import Figure  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from brake_hil.analysis.cycle_metrics import nrmse  # noqa: E402
from brake_hil.diagnosis.candidates import CANDIDATES  # noqa: E402
from brake_hil.diagnosis.diagnose import Diagnosis  # noqa: E402
from brake_hil.diagnosis.evidence import PHASE_BINS  # noqa: E402
from brake_hil.diagnosis.fitting import Model  # noqa: E402
from brake_hil.report.embed import png_data_uri  # noqa: E402
from brake_hil.report.segment_figures import segment_figures  # noqa: E402
from brake_hil.topics import OUTPUT_CHANNELS  # noqa: E402

__all__ = [
    "DPI",
    "TRACES_NRMSE",
    "Figures",
    "figures",
    "harmonics_caption",
    "loop_caption",
    "loop_nrmse",
]

UNITS = {"p_b": ("MPa", 1e-6), "F_k": ("kN", 1e-3), "x_c": ("um", 1e6)}
COLOURS = {"measured": "black", "baseline": "tab:blue", "improved": "tab:red"}
DPI = 130
LEGEND_SIZE = 10
TRACES_NRMSE = 0.1
"""Largest NRMSE (of either coordinate) of a model's loop against the measured one at which
the caption says the model traces it."""
TRACES_WORST = 0.1
"""Largest deviation of a model's loop at any instant from the measured one's, as a share of
the measured loop's span (either coordinate), at which the caption says the model traces it:
a sharp-cornered loop over a rounded one can hold its NRMSE and area and still be seen apart."""
TRACES_AREA = 0.2
"""Largest relative difference of a model's loop area from the measured loop's at which the
caption says the model traces it: the area is the energy the seal dissipates per cycle, which
two coordinates each within ``TRACES_NRMSE`` can still miss (a sharp parallelogram against a
smooth lens)."""


def _held_out_signals(diagnosis: Diagnosis) -> dict[str, dict[str, np.ndarray]]:
    ds = diagnosis.dataset
    window = ds.held_out[0]
    cal = diagnosis.calibration
    result: dict[str, dict[str, np.ndarray]] = {}
    for label, fitted in (("baseline", diagnosis.baseline), ("improved", diagnosis.improved)):
        known = {c.name: c for c in CANDIDATES}
        model = Model(cal, [known[e] for e in fitted.effects if e in known], ds)
        outputs, index = model.simulate(window, fitted.theta[None, :])
        result[label] = {key: outputs[0, c] for c, key in enumerate(OUTPUT_CHANNELS)}
        result["time"] = {"t": ds.time[index]}
        result["measured"] = {key: ds.measured[key][index] for key in OUTPUT_CHANNELS}
    return result


def _time_plot(diagnosis: Diagnosis, data: dict[str, dict[str, np.ndarray]]) -> str:
    time = data["time"]["t"]
    shown = time < time[0] + 4 * diagnosis.dataset.period
    figure, axes = plt.subplots(2, 3, figsize=(15, 7), gridspec_kw={"height_ratios": [3, 1.3]})
    for column, key in enumerate(OUTPUT_CHANNELS):
        unit, scale = UNITS[key]
        top, bottom = axes[0, column], axes[1, column]
        top.plot(
            time[shown],
            data["measured"][key][shown] * scale,
            color=COLOURS["measured"],
            lw=3.0,
            alpha=0.45,
            label="measured",
        )
        for label in ("baseline", "improved"):
            top.plot(
                time[shown],
                data[label][key][shown] * scale,
                "--",
                color=COLOURS[label],
                label=label,
                lw=1.4,
            )
        for label in ("baseline", "improved"):
            bottom.plot(
                time[shown],
                (data[label][key] - data["measured"][key])[shown] * scale,
                color=COLOURS[label],
                lw=1.0,
                label=label,
            )
        top.set_title(f"{key}, held-out cycles", fontsize=11)
        top.set_ylabel(unit)
        bottom.set_ylabel(f"residual, {unit}")
        bottom.set_xlabel("time, s")
        bottom.axhline(0.0, color="grey", lw=0.8)
        for axis in (top, bottom):
            axis.grid(alpha=0.3)
        top.legend(fontsize=LEGEND_SIZE)
    figure.suptitle("measured vs baseline (calibrated LTI) vs improved, on data not fitted")
    return _save(figure)


def _phase_plot(diagnosis: Diagnosis) -> str:
    figure, axis = plt.subplots(figsize=(8, 4.5))
    degrees = (np.arange(PHASE_BINS) + 0.5) * 360.0 / PHASE_BINS
    for key, profile in diagnosis.evidence.phase_profile.items():
        axis.plot(degrees, 100 * np.array(profile), marker="o", ms=3, label=key)
    axis.set_xlabel("phase of the input cycle, deg (0: p_i rising through its mean)")
    axis.set_ylabel("baseline RMS residual, % of ptp")
    axis.set_title("where in the 5 Hz cycle the baseline misses")
    axis.grid(alpha=0.3)
    axis.legend(fontsize=LEGEND_SIZE)
    return _save(figure)


def _harmonics_plot(diagnosis: Diagnosis) -> str:
    harmonics = diagnosis.evidence.harmonics
    keys = list(harmonics.get("measured", {}))
    columns = 2
    rows = max(1, math.ceil(len(keys) / columns))
    figure, axes = plt.subplots(rows, columns, figsize=(12, 3.8 * rows), squeeze=False)
    axes = axes.ravel()
    for spare in axes[len(keys) :]:
        spare.axis("off")
    for axis, key in zip(axes, keys):
        measured = np.array(harmonics["measured"][key])[1:]
        predicted = np.array(harmonics["predicted"][key])[1:]
        orders = np.arange(2, 2 + measured.size) * 5
        axis.bar(orders - 1, measured, width=2, color="black", label="measured")
        axis.bar(orders + 1, predicted, width=2, color="tab:blue", label="baseline")
        axis.set_xticks(orders)
        axis.set_title(f"{key}: super-harmonics (the paper's Table 1)", fontsize=10)
        axis.set_xlabel("Hz")
        axis.set_ylabel("% of energy at 5-25 Hz")
        axis.legend(fontsize=LEGEND_SIZE)
    return _save(figure)


NEGLIGIBLE_HARMONICS_PCT = 0.1
"""Super-harmonic energy (% of the 5-25 Hz energy) under which the bars show only noise."""


def harmonics_caption(harmonics: Mapping[str, Mapping[str, Sequence[float]]]) -> str:
    """What the harmonic bars show, with their largest value (negligible said so)."""
    bars = [v for side in harmonics.values() for key in side.values() for v in list(key)[1:]]
    largest = max(bars, default=0.0)
    text = "Energy at the super-harmonics of 5 Hz, measured against the baseline"
    if largest < NEGLIGIBLE_HARMONICS_PCT:
        return (
            f"{text}: every bar is under {NEGLIGIBLE_HARMONICS_PCT:g} % of the energy "
            f"(largest {largest:.2g} %), so the differences are noise, not a nonlinearity."
        )
    return f"{text} (largest bar {largest:.2g} % of the energy)."


def _seal_loop(
    diagnosis: Diagnosis, signals_of: dict[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """Seal displacement ``x_s = F_k / k_k - x_c`` (m) and force ``F_s = A_ep p_b - F_k`` (N).

    The seed's characterisation (eq. 21e without the piston's small inertia), from the
    30 Hz low-passed signals, so a stick-slip parallelogram keeps its corners.
    """
    window = diagnosis.dataset.held_out[0]
    parameters = diagnosis.calibration.parameters(window.mean_pressure)
    x_s = signals_of["F_k"] / parameters.block_stiffness - signals_of["x_c"]
    f_s = parameters.piston_area * signals_of["p_b"] - signals_of["F_k"]
    return x_s - x_s.mean(), f_s - f_s.mean()


def _loops(
    diagnosis: Diagnosis, data: dict[str, dict[str, np.ndarray]]
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each trace's seal loop over two held-out cycles from the middle of the window."""
    samples = int(round(2 * diagnosis.dataset.period / diagnosis.dataset.sample_time))
    result = {}
    for label in ("measured", "baseline", "improved"):
        x_s, f_s = _seal_loop(diagnosis, data[label])
        middle = x_s.size // 2
        part = slice(middle, middle + samples)
        result[label] = (x_s[part], f_s[part])
    return result


def loop_nrmse(
    model: tuple[np.ndarray, np.ndarray], measured: tuple[np.ndarray, np.ndarray]
) -> float:
    """The NRMSE of a model's loop against the measured loop: the worse of its coordinates.

    Displacement and force, each the paper's NRMSE: RMS error over the measured peak-to-peak.
    """
    return max(nrmse(model[0], measured[0]), nrmse(model[1], measured[1]))


def loop_area_ratio(
    model: tuple[np.ndarray, np.ndarray], measured: tuple[np.ndarray, np.ndarray]
) -> float:
    """The area a model's loop encloses over the measured loop's (shoelace; NaN when flat)."""

    def area(x: np.ndarray, f: np.ndarray) -> float:
        return 0.5 * abs(float(np.sum(x * np.roll(f, -1) - np.roll(x, -1) * f)))

    reference = area(*measured)
    return area(*model) / reference if reference > 0.0 else math.nan


def loop_worst(
    model: tuple[np.ndarray, np.ndarray], measured: tuple[np.ndarray, np.ndarray]
) -> float:
    """A model loop's largest deviation at any instant over the measured span (either axis)."""
    return max(
        float(np.max(np.abs(m - r)) / max(float(np.ptp(r)), 1e-300))
        for m, r in zip(model, measured)
    )


def loop_caption(
    baseline: float, improved: float, area_ratio: float = 1.0, worst: float = 0.0
) -> str:
    """What the loop figure shows, true to its NRMSEs, worst point and areas (``TRACES_*``)."""
    area = f"it encloses {area_ratio:.2f} of the measured loop's area"
    off = f"at worst {100 * worst:.0f} % of its span off"
    if improved <= TRACES_NRMSE and abs(area_ratio - 1.0) <= TRACES_AREA and worst <= TRACES_WORST:
        verdict = (
            f"the improved model traces the measured loop (NRMSE {improved:.2g}, {off}; {area})"
        )
    elif improved <= TRACES_NRMSE:
        verdict = (
            f"<b>the improved model follows the measured loop's extent (NRMSE {improved:.2g}) "
            f"but not its shape</b>: {off}; {area}, the energy the seal loses per cycle"
        )
    else:
        verdict = (
            "<b>the improved model does not trace the measured loop here "
            f"(NRMSE {improved:.2g})</b>: what it adds to the LTI model does not reproduce "
            "the measured loop's shape"
        )
    return (
        f"Seal hysteresis loop, two held-out cycles: {verdict}; the baseline's loop "
        f"NRMSE {baseline:.2g} (NRMSE of the worse of displacement and force)."
    )


def _loop_plot(loops: dict[str, tuple[np.ndarray, np.ndarray]]) -> str:
    figure, axis = plt.subplots(figsize=(7, 5.5))
    for label, (x_s, f_s) in loops.items():
        measured = label == "measured"
        axis.plot(
            x_s * 1e6,
            f_s,
            "-" if measured else "--",
            color=COLOURS[label],
            lw=3.0 if measured else 1.4,
            alpha=0.45 if measured else 1.0,
            label=label,
        )
    axis.set_xlabel("seal displacement x_s = F_k/k_k - x_c, um (mean removed)")
    axis.set_ylabel("seal force F_s = A_ep p_b - F_k, N (mean removed)")
    axis.set_title("seal hysteresis loop, two held-out cycles")
    axis.grid(alpha=0.3)
    axis.legend(fontsize=LEGEND_SIZE)
    return _save(figure)


def _save(figure: Figure) -> str:
    figure.tight_layout()
    return png_data_uri(figure, DPI)


@dataclass(frozen=True)
class Figures:
    """The report's figures (PNG data URIs) with their captions (HTML)."""

    shown: tuple[tuple[str, str, str], ...]  # (data URI, alt text, caption)
    loop_nrmse: dict[str, float]  # baseline, improved: their loop's NRMSE against measured


def figures(diagnosis: Diagnosis) -> Figures:
    """Every figure of the report, in the page's order."""
    data = _held_out_signals(diagnosis)
    loops = _loops(diagnosis, data)
    errors = {
        label: loop_nrmse(loops[label], loops["measured"]) for label in ("baseline", "improved")
    }
    area = loop_area_ratio(loops["improved"], loops["measured"])
    worst = loop_worst(loops["improved"], loops["measured"])
    steady = bool(diagnosis.evidence.phase_profile)  # phase and harmonics need cycles
    shown = (
        (
            _time_plot(diagnosis, data),
            "held-out cycles",
            "Measured, baseline (the calibrated LTI model) and improved model on cycles no "
            "fit saw; residuals below.",
        ),
        *(
            (
                (
                    _phase_plot(diagnosis),
                    "residual over the cycle",
                    "Where in the 5 Hz cycle the baseline misses (its RMS residual per phase "
                    "bin).",
                ),
                (
                    _harmonics_plot(diagnosis),
                    "harmonics",
                    harmonics_caption(diagnosis.evidence.harmonics),
                ),
            )
            if steady
            else ()
        ),
        *(
            (
                (
                    _loop_plot(loops),
                    "seal hysteresis loop",
                    loop_caption(errors["baseline"], errors["improved"], area, worst),
                ),
            )
            if steady  # two held-out cycles; a ramp's loop is on its static map
            else ()
        ),
        *segment_figures(diagnosis),
    )
    return Figures(shown, errors)
