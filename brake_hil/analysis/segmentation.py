"""What a recording holds: its segments of pulsing, sweeps, ramps, holds, steps and idle.

A test procedure chains excitations: pulsing at several pressures, a judder sweep, a slow
ramp and release, an ABS-like train of pressure pulses. :func:`find_segments` splits the
master-cylinder pressure ``p_i`` (30 Hz low-passed, as :mod:`comparison` conditions it) into

* ``pulsing``: a steady oscillation at one frequency (0.5-25 Hz). The steady pulsing at the
  rig file's excitation frequency is :func:`signals.steady_segments`'s, unchanged (its
  segments are ``steady``: the ones the paper's Tables 3-5 are computed on);
* ``sweep``: an oscillation whose frequency moves monotonically (1-30 Hz), linear or log
  in time (``f0_hz``, ``f1_hz``, ``law``);
* ``modulated``: an oscillation that is neither (an ABS-like train of pressure pulses);
* ``ramp``: a rise or fall slower than a step (``rate_pa_per_s``);
* ``step``: an apply or a release within :data:`STEP_MAX_S`;
* ``hold``: a held pressure; ``idle``: the recording's resting level.

How: the oscillations are the runs of at least three alternating turning points (peaks
and troughs more prominent than :data:`PROMINENCE_SHARE` of the recording's range, at
most 1 s apart: 0.5 Hz and up); each cycle's frequency, and its local trend over about a
second, say whether the run is steady (less than :data:`STEADY_TREND_PER_S` relative
change per second), a sweep, or modulated. What is left is cut by the slope of ``p_i``
(2 Hz low-passed): flat below :data:`FLAT_SHARE_PER_S` of the range per second.
Times are accurate to about 0.1 s (steps to about 20 ms); a sweep must move its frequency
by more than 5 % per second to be told from pulsing.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Final

import numpy as np

from brake_hil.analysis import signals
from brake_hil.errors import NoSteadyPulsingError
from brake_hil.types import FloatArray

__all__ = ["KINDS", "Segment", "find_segments"]

KINDS: Final = ("pulsing", "sweep", "modulated", "ramp", "step", "hold", "idle")
"""The segment kinds, oscillations first."""

PROMINENCE_SHARE: Final = 0.04
"""A turning point stands out by this share of the recording's ``p_i`` range."""
MAX_HALF_PERIOD_S: Final = 1.0
"""Turning points further apart end an oscillation (0.5 Hz)."""
GAP_JUMP: Final = 3.0
"""A half period this many times the longest of the four before it ends an oscillation."""
MODULATED_JITTER: Final = 0.15
"""Cycle-to-cycle frequency changes of this median share make the run one modulated train."""
MIN_CYCLES: Final = 3
"""An oscillation holds at least this many cycles."""
STEADY_TREND_PER_S: Final = 0.05
"""A cycle's frequency changing by less than this share per second is steady."""
SWEEP_FIT_R2: Final = 0.9
"""A sweep's frequency follows its law (linear or log in time) at least this well."""
SWEEP_MIN_RATIO: Final = 1.3
"""A sweep ends at least this many times higher (or lower) than it starts."""
FUNDAMENTAL_SHARE: Final = 0.6
"""Steady pulsing carries at least this share of its variance at its fundamental."""
FLAT_SHARE_PER_S: Final = 0.02
"""``p_i`` moving less than this share of its range per second is flat (a hold, idle)."""
STEP_MAX_S: Final = 0.15
"""A rise or fall within this time (10-90 %) is a step, slower is a ramp."""
IDLE_SHARE: Final = 0.05
"""A flat level within this share of the range above the lowest is idle."""
MIN_RANGE_PA: Final = 2.0e4
"""A recording whose ``p_i`` moves less than this (Pa, 0.02 MPa; the sensor's noise is about
1.5 kPa) is idle throughout."""
LEFTOVER_S: Final = 0.3
"""A gap this short beside an oscillation is its unfinished cycle, not a segment of its own."""
MIN_CHANGE_SHARE: Final = 0.05
"""A rise or fall smaller than this share of the range is part of the flat around it."""


@dataclass(frozen=True)
class Segment:
    """One part of a recording (times in s, pressures in Pa, frequencies in Hz)."""

    kind: str  # one of KINDS
    t_start: float  # s
    t_end: float  # s
    descriptors: dict[str, float | str] = field(default_factory=dict)
    steady: bool = False  # today's steady pulsing at the rig's excitation frequency

    @property
    def duration(self) -> float:
        """Length (s)."""
        return self.t_end - self.t_start

    def as_dict(self) -> dict[str, object]:
        """JSON-ready: ``kind``, ``t_start``, ``t_end``, the descriptors, ``steady``."""
        return {
            "kind": self.kind,
            "t_start": self.t_start,
            "t_end": self.t_end,
            **self.descriptors,
            "steady": self.steady,
        }


def find_segments(
    time: FloatArray, pressure: FloatArray, sample_rate: float, excitation_hz: float
) -> list[Segment]:
    """Every segment of a recording, in time order (see the module's docstring).

    Args:
        time: sample times (s), strictly increasing.
        pressure: ``p_i`` (Pa), 30 Hz low-passed.
        sample_rate: samples per second (Hz).
        excitation_hz: the rig file's excitation frequency: the steady pulsing at it is
            :func:`signals.steady_segments`'s.
    """
    try:
        windows = signals.steady_segments(time, pressure, sample_rate, 1.0 / excitation_hz)
    except NoSteadyPulsingError:
        windows = []
    low, high = np.percentile(pressure, [0.5, 99.5])
    scale = float(high - low)
    found = [_pulsing(time, pressure, a, b, excitation_hz, True) for a, b in windows]
    if not scale > MIN_RANGE_PA:
        return [Segment("idle", float(time[0]), float(time[-1]), {"level_pa": float(low)})]
    taken = [(s.t_start, s.t_end) for s in found]
    settling = []  # pulsing at the rig's frequency beside a steady segment: left out, as there
    for segment in _oscillations(time, pressure, scale):
        for start, end in _uncovered(segment.t_start, segment.t_end, taken):
            if _same_pulsing(segment, excitation_hz, start, end, taken):
                settling.append((start, end))
            elif end - start >= MIN_CYCLES / _top_frequency(segment):
                found.append(_clipped(segment, time, pressure, start, end))
            else:
                settling.append((start, end))
    oscillating = [(s.t_start, s.t_end) for s in found]
    taken = sorted([*oscillating, *settling])
    for start, end in _uncovered(float(time[0]), float(time[-1]), taken):
        part = signals.segment_slice(time, start, end + 0.5 / sample_rate)
        beside = any(abs(start - b) < 1e-6 or abs(end - a) < 1e-6 for a, b in oscillating)
        if part.stop - part.start >= 3 and not (beside and end - start < LEFTOVER_S):
            for slow in _slow_segments(time[part], pressure[part], sample_rate, scale, low):
                inside = (max(slow.t_start, start), min(slow.t_end, end))
                found.append(replace(slow, t_start=inside[0], t_end=inside[1]))
    return sorted(found, key=lambda s: s.t_start)


# --------------------------------------------------------------------------- oscillations


def _turning_points(pressure: FloatArray, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices of alternating peaks (+1) and troughs (-1), the more extreme of repeats kept."""
    from scipy.signal import find_peaks  # type: ignore[import-untyped]

    prominence = max(PROMINENCE_SHARE * scale, 0.5 * MIN_RANGE_PA)
    peaks, _ = find_peaks(pressure, prominence=prominence)
    troughs, _ = find_peaks(-pressure, prominence=prominence)
    index = np.concatenate([peaks, troughs])
    sign = np.concatenate([np.ones(peaks.size), -np.ones(troughs.size)])
    order = np.argsort(index)
    kept_index: list[int] = []
    kept_sign: list[float] = []
    for i, s in zip(index[order], sign[order]):
        if kept_sign and kept_sign[-1] == s:
            if s * pressure[i] > s * pressure[kept_index[-1]]:
                kept_index[-1] = int(i)
            continue
        kept_index.append(int(i))
        kept_sign.append(float(s))
    return np.asarray(kept_index, dtype=int), np.asarray(kept_sign)


def _oscillations(time: FloatArray, pressure: FloatArray, scale: float) -> list[Segment]:
    """The oscillating runs of the recording, each split into steady, sweep, modulated."""
    index, _ = _turning_points(pressure, scale)
    if index.size < 2 * MIN_CYCLES + 1:
        return []
    times = time[index]
    gaps = np.diff(times)
    recent = np.array([np.max(gaps[max(k - 4, 0) : k]) if k else np.inf for k in range(gaps.size)])
    breaks = np.flatnonzero((gaps > MAX_HALF_PERIOD_S) | (gaps > GAP_JUMP * recent))
    found: list[Segment] = []
    for run in np.split(np.arange(index.size), breaks + 1):
        if run.size < 2 * MIN_CYCLES + 1:
            continue
        turns = times[run]
        centres, frequencies = _cycle_frequencies(turns)
        jitter = float(np.median(np.abs(frequencies[2:] - frequencies[:-2]) / frequencies[2:]))
        if jitter > MODULATED_JITTER:  # irregular cycles throughout: one modulated train
            start = max(float(turns[0]) - 0.25 / frequencies[0], float(time[0]))
            end = min(float(turns[-1]) + 0.25 / frequencies[-1], float(time[-1]))
            found.append(_modulated(time, pressure, start, end, frequencies))
        else:
            found.extend(_split_run(time, pressure, turns))
    return found


def _cycle_frequencies(turns: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Each cycle's middle (s) and frequency (Hz), from turning points two apart."""
    periods = turns[2:] - turns[:-2]
    return 0.5 * (turns[2:] + turns[:-2]), 1.0 / periods


def _local_trend(centres: FloatArray, frequencies: FloatArray) -> FloatArray:
    """Relative change of the frequency per second (1/s), over about a second around each."""
    logs = np.log(frequencies)
    trend = np.zeros(centres.size)
    for k, centre in enumerate(centres):
        near = np.abs(centres - centre) <= 0.5
        if np.count_nonzero(near) < 3 or np.ptp(centres[near]) <= 0.0:
            near = np.abs(np.arange(centres.size) - k) <= 2
        trend[k] = np.polyfit(centres[near], logs[near], 1)[0]
    return trend


def _split_run(time: FloatArray, pressure: FloatArray, turns: FloatArray) -> list[Segment]:
    """An oscillating run cut where its frequency turns from steady to moving and back."""
    centres, frequencies = _cycle_frequencies(turns)
    steady = np.abs(_local_trend(centres, frequencies)) < STEADY_TREND_PER_S
    edges = np.flatnonzero(np.diff(steady.astype(int))) + 1
    pieces = np.split(np.arange(centres.size), edges)
    merged: list[np.ndarray] = []
    for piece in pieces:  # a piece of fewer than MIN_CYCLES cycles joins the one before
        if merged and piece.size < MIN_CYCLES:
            merged[-1] = np.concatenate([merged[-1], piece])
        else:
            merged.append(piece)
    if len(merged) > 1 and merged[0].size < MIN_CYCLES:
        merged[1] = np.concatenate([merged[0], merged[1]])
        merged = merged[1:]
    found: list[Segment] = []
    for k, piece in enumerate(merged):  # the outer ends reach on to the mean crossing
        start = float(turns[piece[0]]) - (0.25 / frequencies[0] if k == 0 else 0.0)
        end = float(turns[min(piece[-1] + 2, turns.size - 1)])
        end += 0.25 / frequencies[-1] if k == len(merged) - 1 else 0.0
        start, end = max(float(start), float(time[0])), min(float(end), float(time[-1]))
        start = max(start, found[-1].t_end) if found else start
        segment = _classify(time, pressure, start, end, centres[piece], frequencies[piece])
        if found and found[-1].kind == segment.kind == "modulated":
            segment = _modulated(time, pressure, found.pop().t_start, end, frequencies)
        found.append(segment)
    return found


def _modulated(
    time: FloatArray, pressure: FloatArray, start: float, end: float, frequencies: FloatArray
) -> Segment:
    """A modulated train with its mean cycle frequency and level."""
    level = _level(time, pressure, start, end)
    mean = 1.0 / float(np.mean(1.0 / frequencies))
    return Segment("modulated", start, end, {"frequency_hz": mean, **level})


def _classify(
    time: FloatArray,
    pressure: FloatArray,
    start: float,
    end: float,
    centres: FloatArray,
    frequencies: FloatArray,
) -> Segment:
    """A run of cycles as pulsing, a sweep (linear or log) or a modulated train."""
    trend = np.polyfit(centres, np.log(frequencies), 1)[0] if centres.size > 1 else 0.0
    if abs(trend) < STEADY_TREND_PER_S and np.std(frequencies) < 0.1 * np.mean(frequencies):
        frequency = 1.0 / float(np.mean(1.0 / frequencies))  # whole periods: no rounding
        segment = _pulsing(time, pressure, start, end, frequency, False)
        if _fundamental_share(time, pressure, start, end, frequency) >= FUNDAMENTAL_SHARE:
            return segment
        return _modulated(time, pressure, start, end, frequencies)
    fits = {}
    for law, values in (("linear", frequencies), ("log", np.log(frequencies))):
        coefficients = np.polyfit(centres, values, 1)
        residual = values - np.polyval(coefficients, centres)
        total = float(np.sum((values - values.mean()) ** 2))
        fits[law] = (1.0 - float(np.sum(residual**2)) / total if total > 0 else 0.0, coefficients)
    law = max(fits, key=lambda name: fits[name][0])
    r2, coefficients = fits[law]
    level = _level(time, pressure, start, end)
    ends = np.polyval(coefficients, [start, end])
    f0, f1 = (float(v) for v in (np.exp(ends) if law == "log" else ends))
    moved = max(f0, f1) / max(min(f0, f1), 1e-9)
    if r2 < SWEEP_FIT_R2 or moved < SWEEP_MIN_RATIO or centres.size < 2 * MIN_CYCLES:
        return _modulated(time, pressure, start, end, frequencies)
    return Segment("sweep", start, end, {"f0_hz": f0, "f1_hz": f1, "law": law, **level})


def _level(time: FloatArray, pressure: FloatArray, start: float, end: float) -> dict[str, float]:
    """Mean pressure and half the peak-to-peak (Pa) of a span."""
    part = pressure[signals.segment_slice(time, start, end)]
    return {"mean_pressure": float(np.mean(part)), "amplitude_pa": 0.5 * float(np.ptp(part))}


def _pulsing(
    time: FloatArray, pressure: FloatArray, start: float, end: float, hz: float, steady: bool
) -> Segment:
    """A pulsing segment with its frequency and level."""
    level = _level(time, pressure, start, end)
    return Segment(
        "pulsing", float(start), float(end), {"frequency_hz": float(hz), **level}, steady
    )


def _fundamental_share(
    time: FloatArray, pressure: FloatArray, start: float, end: float, hz: float
) -> float:
    """Share of a span's variance at its fundamental ``hz`` (1 for a sine)."""
    part = signals.segment_slice(time, start, end)
    values = pressure[part] - np.mean(pressure[part])
    variance = float(np.var(values))
    if not variance > 0.0:
        return 0.0
    amplitude = abs(signals.harmonic_phasor(values, time[part], hz))
    return 0.5 * amplitude**2 / variance


def _top_frequency(segment: Segment) -> float:
    """The highest frequency of an oscillating segment (Hz)."""
    d = segment.descriptors
    return float(max(float(d.get(key, 0.0)) for key in ("frequency_hz", "f0_hz", "f1_hz")))


def _same_pulsing(
    segment: Segment, hz: float, start: float, end: float, taken: list[tuple[float, float]]
) -> bool:
    """A piece of pulsing at the rig's frequency next to a steady segment: its settling."""
    if (
        segment.kind != "pulsing"
        or abs(float(segment.descriptors["frequency_hz"]) / hz - 1) > 0.05
    ):
        return False
    return any(start <= b + 0.5 and end >= a - 1.5 for a, b in taken)


def _clipped(
    segment: Segment, time: FloatArray, pressure: FloatArray, start: float, end: float
) -> Segment:
    """``segment`` cut to ``[start, end)``; a sweep's end frequencies follow its law."""
    if (start, end) == (segment.t_start, segment.t_end):
        return segment
    d = dict(segment.descriptors)
    if segment.kind == "sweep":
        f0, f1 = float(d["f0_hz"]), float(d["f1_hz"])
        share = [(t - segment.t_start) / segment.duration for t in (start, end)]
        if d["law"] == "log":
            d["f0_hz"], d["f1_hz"] = (float(f0 * (f1 / f0) ** s) for s in share)
        else:
            d["f0_hz"], d["f1_hz"] = (float(f0 + (f1 - f0) * s) for s in share)
    d.update(_level(time, pressure, start, end))
    return Segment(segment.kind, start, end, d)


def _uncovered(
    start: float, end: float, taken: list[tuple[float, float]]
) -> list[tuple[float, float]]:
    """The parts of ``[start, end]`` outside every ``taken`` interval."""
    pieces = [(start, end)]
    for a, b in taken:
        pieces = [
            part
            for lo, hi in pieces
            for part in ((lo, min(hi, a)), (max(lo, b), hi))
            if part[1] - part[0] > 1e-9
        ]
    return pieces


# --------------------------------------------------------------------------- slow parts


def _slow_segments(
    time: FloatArray, pressure: FloatArray, rate: float, scale: float, low: float
) -> list[Segment]:
    """Ramps, steps, holds and idle in a span without oscillation."""
    if time.size > 30:
        slow = signals.lowpass(pressure, rate, cutoff_hz=2.0)
        slope = np.gradient(slow, time)
    else:
        slow, slope = pressure, np.gradient(pressure, time)
    direction = np.where(slope > FLAT_SHARE_PER_S * scale, 1, 0)
    direction = np.where(slope < -FLAT_SHARE_PER_S * scale, -1, direction)
    runs = _runs(direction, max(int(0.1 * rate), 1))
    found: list[Segment] = []
    for first, last, sign in runs:
        change = float(slow[last] - slow[first])
        if sign != 0 and abs(change) >= MIN_CHANGE_SHARE * scale:
            found.append(_sloped(time, pressure, first, last))
            continue
        level = float(np.median(pressure[first : last + 1]))
        kind = "idle" if level - low < IDLE_SHARE * scale else "hold"
        found.append(Segment(kind, float(time[first]), float(time[last]), {"level_pa": level}))
    return _flats_joined(found)


def _flats_joined(found: list[Segment]) -> list[Segment]:
    """Holds and idle stretched to the steps beside them, repeats joined, short ones left out."""
    stretched = list(found)
    for k, segment in enumerate(found):
        if segment.kind not in ("hold", "idle"):
            continue
        start, end = segment.t_start, segment.t_end
        if k > 0 and found[k - 1].kind == "step":
            start = found[k - 1].t_end
        if k + 1 < len(found) and found[k + 1].kind == "step":
            end = found[k + 1].t_start
        stretched[k] = Segment(segment.kind, start, end, segment.descriptors)
    joined: list[Segment] = []
    for segment in stretched:
        if joined and joined[-1].kind == segment.kind and segment.kind in ("hold", "idle"):
            previous = joined.pop()
            segment = Segment(segment.kind, previous.t_start, segment.t_end, previous.descriptors)
        joined.append(segment)
    return [s for s in joined if s.kind not in ("hold", "idle") or s.duration >= LEFTOVER_S]


def _runs(labels: np.ndarray, shortest: int) -> list[tuple[int, int, int]]:
    """Runs ``(first, last, label)`` of equal labels, runs shorter than ``shortest`` merged."""
    edges = np.flatnonzero(np.diff(labels)) + 1
    runs = [
        [int(p[0]), int(p[-1]), int(labels[p[0]])] for p in np.split(np.arange(labels.size), edges)
    ]
    merged: list[list[int]] = []
    for run in runs:
        if merged and (run[1] - run[0] + 1 < shortest or merged[-1][2] == run[2]):
            merged[-1][1] = run[1]
        else:
            merged.append(run)
    return [(a, b, c) for a, b, c in merged]


def _sloped(time: FloatArray, pressure: FloatArray, first: int, last: int) -> Segment:
    """A rise or fall: a step when its 10-90 % transition is within STEP_MAX_S, else a ramp."""
    part = pressure[first : last + 1]
    t = time[first : last + 1]
    start_level, end_level = float(np.median(part[:5])), float(np.median(part[-5:]))
    change = end_level - start_level
    progress = (part - start_level) / change
    reached = np.maximum.accumulate(progress)

    def above(share: float) -> float:
        """When the transition has first covered ``share`` of its change (s)."""
        return float(t[min(int(np.searchsorted(reached, share)), t.size - 1)])

    t10, t90 = above(0.1), above(0.9)
    rising = change > 0
    if t90 - t10 <= STEP_MAX_S:
        d: dict[str, float | str] = {
            "direction": "apply" if rising else "release",
            "from_pa": start_level,
            "to_pa": end_level,
            "rise_time_s": t90 - t10,
        }
        return Segment("step", above(0.02), above(0.98), d)
    t0, t1 = above(0.02), above(0.98)
    rate = change * 0.8 / (t90 - t10)
    d = {
        "direction": "rise" if rising else "fall",
        "rate_pa_per_s": rate,
        "from_pa": start_level,
        "to_pa": end_level,
    }
    return Segment("ramp", t0, t1, d)
