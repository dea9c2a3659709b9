"""Locate the mismatch between the calibrated LTI baseline and a recording.

Each finding is a number with a sentence: which channels are off and by how much, which time
windows, at which phase of the 5 Hz cycle, which harmonics grow from input to output beyond
what the model makes (seed Table 1), how the seal's effective stiffness changes with the
pressure amplitude (seed Table 3), whether the mismatch drifts over the recording, and whether
one channel lags the others.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from brake_hil.analysis import signals
from brake_hil.diagnosis import segment_evidence
from brake_hil.diagnosis.dataset import Dataset
from brake_hil.diagnosis.fitting import Model
from brake_hil.diagnosis.segment_evidence import SegmentSignals
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray
from brake_hil.words import energy_share

MISMATCH_RMS = 0.01
"""A channel whose baseline held-out RMS exceeds this (1 % of its peak-to-peak) is mismatched."""
PHASE_BINS = 24
EVEN_CHUNKS = 8
"""Pieces each steady segment is cut into to measure the scatter of its even harmonics."""


@dataclass(frozen=True)
class Evidence:
    """Numbers (``values``) and sentences (``findings``) about the baseline's mismatch."""

    values: dict[str, float]
    findings: list[str]
    channels: list[str]  # mismatched channels, worst first
    windows: list[tuple[float, float]]  # s, where the mismatch is largest
    phase_profile: dict[str, list[float]] = field(default_factory=dict)  # RMS residual per bin
    harmonics: dict[str, dict[str, list[float]]] = field(default_factory=dict)


def segment_signals(model: Model, theta: FloatArray) -> list[SegmentSignals]:
    """Simulate ``model`` over every segment's window of its dataset."""
    ds = model.dataset
    result = []
    for window in ds.segments:
        outputs, index = model.simulate(window, theta[None, :])
        result.append(
            SegmentSignals(
                window=window,
                time=ds.time[index],
                pressure=ds.pressure[index],
                measured={key: ds.measured[key][index] for key in OUTPUT_CHANNELS},
                predicted={key: outputs[0, c] for c, key in enumerate(OUTPUT_CHANNELS)},
            )
        )
    return result


def _lag(predicted: FloatArray, measured: FloatArray, sample_time: float) -> float:
    """Delay (s) of ``measured`` behind ``predicted`` from the peak of their correlation."""
    a = predicted - predicted.mean()
    b = measured - measured.mean()
    max_shift = int(round(0.03 / sample_time))
    shifts = np.arange(-max_shift, max_shift + 1)
    scores = [
        float(np.dot(a[max(0, -s) : a.size - max(0, s)], b[max(0, s) : b.size - max(0, -s)]))
        for s in shifts
    ]
    best = int(np.argmax(scores))
    if 0 < best < shifts.size - 1:  # parabolic refinement
        y0, y1, y2 = scores[best - 1], scores[best], scores[best + 1]
        denominator = y0 - 2 * y1 + y2
        offset = 0.5 * (y0 - y2) / denominator if denominator != 0 else 0.0
    else:
        offset = 0.0
    return float((shifts[best] + offset) * sample_time)


def collect(
    model: Model, theta: FloatArray, k_eh_by_segment: list[tuple[float, float]]
) -> Evidence:
    """Evidence of the mismatch of ``model`` (the calibrated baseline) against its data.

    ``k_eh_by_segment`` pairs each segment's bore-pressure peak-to-peak (Pa) with its
    characterised ``k_eh`` (N/m), for the amplitude trend.
    """
    parts = segment_signals(model, theta)
    found = _Findings(model.dataset, parts)
    channels, worst = found.overall()
    windows = found.per_segment(worst)
    profile: dict[str, list[float]] = {}
    harmonics: dict[str, dict[str, list[float]]] = {}
    if found.steady:  # the cycle's phase, harmonics and drift need steady pulsing
        profile = found.phase(worst)
        harmonics = found.harmonics()
        found.amplitude_trend(k_eh_by_segment)
        found.drift()
    found.lags()
    others = [p for p in parts if p.window.kind != "steady"]
    if others:
        values, findings = segment_evidence.collect(model.dataset, others)
        found.values.update(values)
        found.findings.extend(findings)
    return Evidence(found.values, found.findings, channels, windows, profile, harmonics)


class _Findings:
    """The evidence's numbers and sentences, gathered step by step over the segments."""

    def __init__(self, dataset: Dataset, parts: list[SegmentSignals]) -> None:
        self.ds = dataset
        self.parts = parts
        self.steady = [p for p in parts if p.window.kind == "steady"]  # steady pulsing
        self.scale = dataset.scale()
        self.values: dict[str, float] = {}
        self.findings: list[str] = []

    def overall(self) -> tuple[list[str], str]:
        """Each channel's RMS residual and the noise: the mismatched channels and the worst."""
        values, parts, scale = self.values, self.parts, self.scale
        residuals = {
            key: np.concatenate([(p.predicted[key] - p.measured[key]) / scale[key] for p in parts])
            for key in OUTPUT_CHANNELS
        }
        nrmse = {key: float(np.sqrt(np.mean(r**2))) for key, r in residuals.items()}
        for key in OUTPUT_CHANNELS:
            values[f"held_out_rms_{key}"] = nrmse[key]
        channels = sorted(
            (k for k in OUTPUT_CHANNELS if nrmse[k] > MISMATCH_RMS), key=lambda k: -nrmse[k]
        )
        worst = max(nrmse, key=lambda k: nrmse[k])
        over = "the steady cycles" if len(self.steady) == len(parts) else "its segments"
        self.findings.append(
            f"calibrated LTI baseline's RMS residual over {over}, in % of the whole "
            "recording's peak-to-peak (the fits' measure, not the paper's per-window NRMSE): "
            + ", ".join(f"{k} {100 * v:.2f} %" for k, v in nrmse.items())
            + (f"; mismatched: {', '.join(channels)}" if channels else "; no channel above 1 %")
        )
        noise = self.ds.noise_cost()
        how = "cycle-to-cycle" if self.steady else "raw channels above 150 Hz"
        misfit = float(np.mean([v**2 for v in nrmse.values()]))
        values["noise_nrmse"] = float(np.sqrt(noise))
        values["misfit_over_noise"] = misfit / max(noise, 1e-18)
        self.findings.append(
            f"measurement noise ({how}): {100 * np.sqrt(noise):.3f} % of peak-to-peak; "
            f"the baseline's squared error is {values['misfit_over_noise']:.1f} times the noise's"
        )
        return channels, worst

    def per_segment(self, worst: str) -> list[tuple[float, float]]:
        """The worst channel's residual per segment and its trend; the mismatched windows (s)."""
        parts, scale = self.parts, self.scale
        windows: list[tuple[float, float]] = []
        per_segment = []
        for part in parts:
            seg = {
                k: float(
                    np.sqrt(np.mean(((part.predicted[k] - part.measured[k]) / scale[k]) ** 2))
                )
                for k in OUTPUT_CHANNELS
            }
            per_segment.append(seg)
            if seg[worst] > MISMATCH_RMS:
                windows.append((part.window.start, part.window.end))
        if len(parts) > 1:
            self.findings.append(
                f"{worst} RMS residual per segment, same measure (mean p_i): "
                + ", ".join(
                    f"{100 * s[worst]:.2f} % ({p.window.mean_pressure / 1e6:.2f} MPa)"
                    for s, p in zip(per_segment, parts)
                )
            )
            first, last = per_segment[0][worst], per_segment[-1][worst]
            average = float(np.mean([s[worst] for s in per_segment]))
            self.values["segment_trend"] = (last - first) / max(average, 1e-12)
        return windows

    def phase(self, worst: str) -> dict[str, list[float]]:
        """RMS residual per phase bin of the 5 Hz input cycle, by channel; where it peaks."""
        profile: dict[str, list[float]] = {}
        for key in OUTPUT_CHANNELS:
            bins = np.zeros(PHASE_BINS)
            counts = np.zeros(PHASE_BINS)
            for part in self.steady:
                phase = _input_phase(part.time, part.pressure, self.ds.period)
                index = np.minimum((phase / (2 * np.pi) * PHASE_BINS).astype(int), PHASE_BINS - 1)
                r = (part.predicted[key] - part.measured[key]) / self.scale[key]
                np.add.at(bins, index, r**2)
                np.add.at(counts, index, 1)
            profile[key] = np.sqrt(bins / np.maximum(counts, 1)).tolist()
        peak_bin = int(np.argmax(profile[worst]))
        concentration = max(profile[worst]) / max(float(np.mean(profile[worst])), 1e-12)
        self.values["phase_concentration"] = float(concentration)
        self.values["phase_peak_deg"] = float((peak_bin + 0.5) * 360.0 / PHASE_BINS)
        self.findings.append(
            f"{worst} residual peaks at {self.values['phase_peak_deg']:.0f} deg of the input "
            f"cycle (0 deg: p_i rising through its mean), {concentration:.1f} times its cycle mean"
        )
        return profile

    def harmonics(self) -> dict[str, dict[str, list[float]]]:
        """Harmonics (seed Table 1): growth from input to output, measured against predicted."""
        parts, values = self.steady, self.values
        harmonics: dict[str, dict[str, list[float]]] = {"measured": {}, "predicted": {}}
        rate = 1.0 / self.ds.sample_time

        def shares(signal: FloatArray) -> FloatArray:
            return signals.harmonic_energy_shares(signal, rate, 1.0 / self.ds.period)

        for key in ("p_i", *OUTPUT_CHANNELS):
            measured_shares = np.mean(
                [shares(p.pressure if key == "p_i" else p.measured[key]) for p in parts], axis=0
            )
            predicted_shares = np.mean(
                [shares(p.pressure if key == "p_i" else p.predicted[key]) for p in parts], axis=0
            )
            harmonics["measured"][key] = measured_shares.tolist()
            harmonics["predicted"][key] = predicted_shares.tolist()
        input_super = 100.0 - harmonics["measured"]["p_i"][0]
        for key in OUTPUT_CHANNELS:
            measured = np.array(harmonics["measured"][key])
            predicted = np.array(harmonics["predicted"][key])
            growth = (100.0 - measured[0]) - (100.0 - predicted[0])
            values[f"harmonic_growth_{key}"] = float(growth)
            values[f"even_harmonics_{key}"] = float(
                (measured[1] + measured[3]) - (predicted[1] + predicted[3])
            )
        _, z, power = even_harmonics_z(
            self.steady, "p_b", rate, 1.0 / self.ds.period, self.scale["p_b"]
        )
        values["even_harmonics_z_p_b"] = z
        values["even_harmonics_power_p_b"] = power
        self.findings.append(
            f"p_b's even harmonics (10 and 20 Hz) beyond the model's: "
            f"{energy_share(values['even_harmonics_p_b'])} of its energy, {z:.1f} standard "
            "errors of their scatter over the cycles (a compliance that changes with pressure, "
            "as air's, makes them; a law the same on apply and release does not)"
        )
        self.findings.append(
            "super-harmonic energy (10-25 Hz) beyond the model's: "
            + ", ".join(f"{k} {values[f'harmonic_growth_{k}']:+.2f} %" for k in OUTPUT_CHANNELS)
            + f" (input p_i carries {input_super:.2f} %)"
        )
        return harmonics

    def amplitude_trend(self, k_eh_by_segment: list[tuple[float, float]]) -> None:
        """Amplitude dependence of ``k_eh`` (seed Table 3), with two segments or more."""
        if len(k_eh_by_segment) < 2:
            return
        amplitude = np.array([a for a, _ in k_eh_by_segment])
        stiffness = np.array([k for _, k in k_eh_by_segment])
        slope = np.polyfit(np.log(amplitude), np.log(np.maximum(stiffness, 1.0)), 1)[0]
        self.values["k_eh_trend"] = float(slope)
        self.findings.append(
            f"k_eh changes as (bore peak-to-peak)^{slope:+.2f} across the segments "
            "(an LTI seal gives 0; stick-slip friction makes it fall)"
        )

    def drift(self) -> None:
        """Drift over the recording: the per-cycle peak-to-peak ratio's trend in segments."""
        ds, parts = self.ds, self.steady
        drift = 0.0
        duration = parts[-1].window.end - parts[0].window.start
        for key in OUTPUT_CHANNELS:
            times, ratios = [], []
            for part in parts:
                for start in np.arange(
                    part.window.start, part.window.end - ds.period + 1e-9, ds.period
                ):
                    cycle = (part.time >= start) & (part.time < start + ds.period)
                    measured_ptp = np.ptp(part.measured[key][cycle])
                    if measured_ptp > 0:
                        times.append(start)
                        ratios.append(np.ptp(part.predicted[key][cycle]) / measured_ptp)
            if len(times) > 4:
                within = _within_segment_slope(np.array(times), np.array(ratios), parts)
                drift_key = float(within * duration)
                self.values[f"drift_{key}"] = drift_key
                if abs(drift_key) > abs(drift):
                    drift = drift_key
        self.values["drift"] = drift
        self.findings.append(
            f"within-segment drift of the predicted/measured peak-to-peak ratio over the "
            f"recording: {100 * drift:+.1f} %"
        )

    def lags(self) -> None:
        """How far each measured channel lags its prediction (ms), and their spread."""
        values = self.values
        for key in OUTPUT_CHANNELS:
            lag = np.mean(
                [_lag(p.predicted[key], p.measured[key], self.ds.sample_time) for p in self.parts]
            )
            values[f"lag_{key}_ms"] = float(1e3 * lag)
        lags = [values[f"lag_{k}_ms"] for k in OUTPUT_CHANNELS]
        values["lag_spread_ms"] = float(max(lags) - min(lags))
        self.findings.append(
            "measured behind predicted: "
            + ", ".join(f"{k} {values[f'lag_{k}_ms']:+.2f} ms" for k in OUTPUT_CHANNELS)
        )


def _input_phase(time: FloatArray, pressure: FloatArray, period: float) -> FloatArray:
    """Phase (rad, 0..2pi) of each sample in the input's cycle, 0 at its rising mean crossing."""
    phasor = signals.harmonic_phasor(pressure, time, 1.0 / period)
    # p_i ~ |X| cos(wt + arg X); it rises through its mean where wt + arg X = -pi/2.
    return np.mod(2 * np.pi * time / period + np.angle(phasor) + np.pi / 2, 2 * np.pi)


def _within_segment_slope(
    times: FloatArray, ratios: FloatArray, parts: list[SegmentSignals]
) -> float:
    """Slope (1/s) of ``ratios`` against time, with each segment's own mean removed."""
    centred_t, centred_r = [], []
    for part in parts:
        inside = (times >= part.window.start) & (times < part.window.end)
        if inside.sum() > 2:
            centred_t.append(times[inside] - times[inside].mean())
            centred_r.append(ratios[inside] - ratios[inside].mean())
    if not centred_t:
        return 0.0
    t = np.concatenate(centred_t)
    r = np.concatenate(centred_r)
    return float(np.dot(t, r) / max(float(np.dot(t, t)), 1e-12))


def _even_share(signal: FloatArray, rate: float, fundamental: float) -> float | None:
    """Share (%) of the 2nd and 4th harmonics in the first five, less the noise's part.

    As :func:`.signals.harmonic_energy_shares` (whole cycles, each harmonic's bin and its two
    neighbours), but the noise's energy per bin, the mean of the bins between the harmonics,
    is taken off every harmonic's: noise adds energy to every bin, so without it a noisy
    measurement shows even harmonics a noise-free prediction lacks. None: under two cycles.
    """
    cycles = int(signal.size * fundamental / rate)
    length = int(round(cycles * rate / fundamental))
    if cycles < 2 or length > signal.size or 5 * cycles + 1 >= length // 2:
        return None
    x = signal[:length] - float(np.mean(signal[:length]))
    energy = np.abs(np.fft.rfft(x)) ** 2
    near = np.zeros(energy.size, dtype=bool)
    bins = []
    for k in range(1, 6):
        band = np.arange(k * cycles - 1, k * cycles + 2)
        near[band] = True
        bins.append(float(np.sum(energy[band])))
    between = ~near
    between[:cycles] = False
    between[5 * cycles + 2 :] = False
    noise = float(np.mean(energy[between])) if between.any() else 0.0
    shares = np.array(bins) - 3.0 * noise
    total = float(np.sum(shares))
    if total <= 0.0:
        return None
    return float(100.0 * (shares[1] + shares[3]) / total)


def even_harmonics_left(model: Model, theta: FloatArray) -> tuple[float, float, float]:
    """The even harmonics of ``p_b`` ``model`` leaves at ``theta`` (:func:`even_harmonics_z`).

    Over the steady pulsing segments only: harmonics of the pulsing frequency mean nothing
    on a sweep or a ramp.
    """
    ds = model.dataset
    return even_harmonics_z(
        [p for p in segment_signals(model, theta) if p.window.kind == "steady"],
        "p_b",
        1.0 / ds.sample_time,
        1.0 / ds.period,
        ds.scale()["p_b"],
    )


def even_harmonics_z(
    parts: list[SegmentSignals], key: str, rate: float, fundamental: float, scale: float = 1.0
) -> tuple[float, float, float]:
    """Even harmonics of ``key`` the model does not make: their share (%), its z, their power.

    Each steady segment is cut into ``EVEN_CHUNKS`` pieces of whole cycles; on each, the
    measured share of energy at the 2nd and 4th harmonics less the predicted one. The share
    is the mean over every piece; z, that mean over its standard error: the scatter of the
    pieces about their own segment's mean (what the noise and the cycle-to-cycle changes
    make; 0 when it cannot be measured, too few pieces). The power is the share times the
    measured mean square, over ``scale`` squared: on the held-out costs' scale when
    ``scale`` is the channel's peak-to-peak (``Dataset.scale``). A law the same on apply and
    release (an LTI model, stick-slip, an orifice) adds no even harmonics to a symmetric
    cycle; one that changes with the pressure (air's compliance, a load share) does.
    """
    excess: list[list[float]] = []
    powers: list[float] = []
    for part in parts:
        size = part.time.size // EVEN_CHUNKS
        pieces = []
        for i in range(EVEN_CHUNKS):
            piece = part.measured[key][i * size : (i + 1) * size]
            measured = _even_share(piece, rate, fundamental)
            predicted = _even_share(
                part.predicted[key][i * size : (i + 1) * size], rate, fundamental
            )
            if measured is not None and predicted is not None:
                pieces.append(measured - predicted)
                powers.append((measured - predicted) / 100.0 * float(np.var(piece)) / scale**2)
        if len(pieces) > 1:
            excess.append(pieces)
    count = sum(len(p) for p in excess)
    freedom = count - len(excess)
    if freedom < 1:
        return 0.0, 0.0, 0.0
    scatter = sum(float(np.sum((np.array(p) - np.mean(p)) ** 2)) for p in excess) / freedom
    mean = float(np.mean([v for p in excess for v in p]))
    return mean, mean / max(float(np.sqrt(scatter / count)), 1e-12), float(np.mean(powers))
