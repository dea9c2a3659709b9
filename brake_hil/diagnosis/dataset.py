"""A recording prepared for diagnosis: conditioned signals, windows, train/held-out split.

The split keeps the held-out data out of every fit, within each segment kind, so every model
must predict what it did not see:

* steady pulsing (at the rig file's excitation frequency): the last 40 % of every steady
  segment's cycles is held out. Every pressure amplitude is then seen in training (the
  amplitude dependence is learnt, as the seed learns k_eh per experiment), and every
  candidate must predict cycles later in time than any it was fitted on, which is what
  exposes a drift. (A held-out middle segment would hide a drift: a calibration fitted to
  both ends is right in the middle.)
* pulsing at another frequency: the same, in its own cycles;
* a sweep or a modulated train: its last 40 % in time (for a sweep, the band of frequencies
  it ends on: a model fitted on 5-17 Hz must predict 17-25 Hz);
* slow ramps (at least ``SLOW_RAMP_S``): the later ramps when there are ``LATER_RAMPS`` or
  more (a second rise and fall), else the last 40 % of each (the top of a rise, the bottom
  of a fall): every model sees both an apply and a release.

A recording with steady pulsing keeps today's windows; sweeps, other pulsing, modulated
trains and slow ramps beside it are added. Short rises (the approach to a pulsing level),
steps, holds and idle are not windows; the simulation of a window that is not pulsing starts
up to ``LEAD_IN_S`` before it (a ramp's seal remembers the rise before its fall).

Signals are conditioned as the seed does (30 Hz zero-phase low-pass) and decimated to
``DIAGNOSIS_RATE`` for the fits (the 5 Hz excitation's first five harmonics stay far below
its Nyquist frequency).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.interpolate import CubicSpline  # type: ignore[import-untyped]

from brake_hil.analysis import signals
from brake_hil.analysis.comparison import conditioned_channels
from brake_hil.analysis.recording import Recording
from brake_hil.analysis.saturation import Held, held_limits
from brake_hil.analysis.segmentation import Segment, find_segments
from brake_hil.errors import SignalError
from brake_hil.physics.measurement import SENSORS
from brake_hil.physics.rig import Rig
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray

DIAGNOSIS_RATE = 500.0
"""Sample rate (Hz) of the signals the diagnosis fits."""
HELD_OUT_SHARE = 0.4
SLOW_RAMP_S = 2.0
"""A ramp lasting at least this long (s) is a window: a slow ramp maps the static response;
a shorter rise is the approach to a pulsing level."""
LATER_RAMPS = 4
"""With this many slow ramps (two rises and two falls) the later ones are held out; with
fewer, the last ``HELD_OUT_SHARE`` of each: fitted on a rise alone, a seal's release is not
identified (its release stiffness came out unbounded on the bundled ramp)."""
LEAD_IN_S = 6.0
"""A window that is not pulsing is simulated from up to this long before it (s), so that
its history (the rise before a fall, the ramp before a sweep) is in its prediction."""
ZERO_LEVELLED_KINDS = frozenset({"steady", "pulsing", "sweep", "modulated"})
"""Window kinds over which the bore pressure's zero may sit off the master cylinder's
(``ZERO_STABILITY``): over whole cycles a mean offset carries no dynamics (the seed's
Table 4-5 metrics are peak-to-peak and phase). A ramp keeps its levels: its static map and
its loop's gap are what it shows."""
ZERO_STABILITY = 1e-3
"""How far (share of the full scale) a pressure transducer's zero may wander in a recording.

Zeroed before the run, a strain-gauge or piezoresistive transducer drifts by its thermal
zero shift (0.01-0.02 % of full scale per kelvin on a datasheet) over a few kelvin: 0.1 %
of the seed rig's 6.9 MPa range is 6.9 kPa, a few times the sensor noise yet tens of times
the noise of the 30 Hz conditioned channels. Over whole cycles ``p_b``'s mean equals
``p_i``'s in every model (no flow at rest; the candidates' flows average to zero), so their
mean difference within this bound is taken as the two zeros'; beyond it the rest stays in
the residual (a zero shift, a leak). ``F_k`` and ``x_c`` keep their levels: a seal's rest
position and the groove's creep show there; their transducers' zeros are taken to wander as
much (a load cell's and a probe's thermal zero shift are of the same order), which a drift
must be told from (``candidates.zero_wander``)."""
NOISE_BAND_HZ = 150.0
"""The raw channels above this frequency hold noise alone (no segment kind reaches it): the
estimate of the noise where nothing repeats (:func:`noise_variances`)."""


@dataclass(frozen=True)
class Window:
    """A span of whole cycles (s) and the mean master-cylinder pressure over it (Pa)."""

    start: float
    end: float
    mean_pressure: float
    segment: int  # index of the segment it belongs to
    kind: str = "steady"  # steady (pulsing at the rig's frequency), or a segmentation kind
    lead_in: float = 0.0  # s simulated before ``start`` at least (a ramp's history)
    capped: bool = True  # a fit takes only its first FIT_SPAN s (steady pulsing repeats)
    period: float = 0.0  # s, of a pulsing window (0 for the others)


@dataclass(frozen=True)
class Dataset:
    """Conditioned, decimated signals of one recording and its windows."""

    name: str
    time: FloatArray  # s, at DIAGNOSIS_RATE
    pressure: FloatArray  # p_i, Pa (low-passed)
    measured: dict[str, FloatArray]  # p_b, F_k, x_c (low-passed)
    train: tuple[Window, ...]
    held_out: tuple[Window, ...]
    segments: tuple[Window, ...]
    period: float  # s
    sample_time: float  # s
    noise_variance: dict[str, float] | None = None  # conditioned noise (no steady window)
    found: tuple[Segment, ...] = ()  # every segment of the recording (segmentation)
    held: dict[str, Held] = field(default_factory=dict)  # outputs held at a range's end

    def mask(self, windows: tuple[Window, ...]) -> FloatArray:
        """Boolean mask of the samples inside ``windows``."""
        inside = np.zeros(self.time.size, dtype=bool)
        for window in windows:
            inside |= (self.time >= window.start - 1e-9) & (self.time < window.end - 1e-9)
        return inside

    def scale(self) -> dict[str, float]:
        """Peak-to-peak of each measured channel over the segments (normaliser)."""
        inside = self.mask(self.segments)
        return {key: float(np.ptp(value[inside])) for key, value in self.measured.items()}

    def noise_cost(self) -> float:
        """The held-out cost a perfect model would still have: the measurement's own noise.

        Under steady pulsing a noise-free output repeats every period, so the difference of
        a sample and the value a period earlier is noise (twice its variance) plus what
        changed in one cycle. Mean over channels of that variance over the squared
        peak-to-peak, the normalisation of ``Fit.held_out_cost``. A period of no whole number
        of samples (8 Hz at 500 Hz: 62.5) takes the value a period earlier off a cubic spline
        through the samples: a lag rounded to whole samples would count the signal's change
        over the half sample as noise (300-2000 times the noise on four 8 Hz recordings). The
        conditioned signals are low-passed far below the sample rate, so their noise keeps
        its variance through the interpolation.

        With no steady pulsing, nothing repeats: the noise is the raw channels' own above
        ``NOISE_BAND_HZ``, carried to the conditioned band (:func:`noise_variances`).
        """
        steady = tuple(w for w in self.segments if w.kind == "steady")
        if not steady:
            return self._noise_without_cycles()
        per_period = self.period / self.sample_time
        lag = int(round(per_period))
        whole = abs(per_period - lag) < 1e-6
        scale = self.scale()
        costs = []
        for key, value in self.measured.items():
            differences = []
            for window in steady:
                part = value[self.mask((window,))]
                if part.size <= lag:
                    continue
                if whole:
                    differences.append(part[lag:] - part[:-lag])
                else:
                    positions = np.arange(part.size, dtype=float)
                    later = positions >= per_period
                    spline = CubicSpline(positions, part)
                    differences.append(part[later] - spline(positions[later] - per_period))
            variance = float(np.mean(np.concatenate(differences) ** 2)) / 2 if differences else 0
            costs.append(variance / max(scale[key], 1e-30) ** 2)
        return float(np.mean(costs))

    def _noise_without_cycles(self) -> float:
        """:meth:`noise_cost` from ``noise_variance`` (0 when it is not known)."""
        if not self.noise_variance:
            return 0.0
        scale = self.scale()
        return float(
            np.mean([v / max(scale[key], 1e-30) ** 2 for key, v in self.noise_variance.items()])
        )

    @property
    def steady(self) -> bool:
        """Every window is steady pulsing at the rig's frequency (today's recordings)."""
        return all(w.kind == "steady" for w in self.segments)


def prepare(recording: Recording, rig: Rig) -> Dataset:
    """Condition, decimate and split a recording (see the module docstring).

    Raises:
        SignalError: nothing to diagnose (no pulsing, sweep, modulated train or slow
            ramp), naming the recording.
    """
    filtered = conditioned_channels(recording)
    rate = recording.sample_rate
    found = find_segments(recording.time, filtered["p_i"], rate, rig.excitation_hz)
    period = 1.0 / rig.excitation_hz
    segments: list[Window] = []
    for start, end in [(s.t_start, s.t_end) for s in found if s.steady]:
        part = signals.segment_slice(recording.time, start, end)
        mean = float(np.mean(filtered["p_i"][part]))
        segments.append(Window(start, end, mean, len(segments), period=period))
    for segment in found:
        if _usable(segment):
            part = signals.segment_slice(recording.time, segment.t_start, segment.t_end)
            mean = float(np.mean(filtered["p_i"][part]))
            segments.append(_window(segment, mean, len(segments), float(recording.time[0])))
    if not segments:
        raise SignalError(
            f"{recording.path}: nothing to diagnose: no pulsing, sweep, modulated train or "
            f"ramp of at least {SLOW_RAMP_S:g} s (segments: "
            f"{', '.join(s.kind for s in found) or 'none'})"
        )
    ordered = sorted(segments, key=lambda w: w.start)  # in time (the index is its place)
    segments = [replace(w, segment=k) for k, w in enumerate(ordered)]
    train, held_out = split(segments)
    step = max(int(round(rate / DIAGNOSIS_RATE)), 1)
    time = recording.time[::step]
    steady = any(w.kind == "steady" for w in segments)
    return Dataset(
        name=str(recording.path),
        time=time,
        pressure=filtered["p_i"][::step],
        measured={key: filtered[key][::step] for key in OUTPUT_CHANNELS},
        train=train,
        held_out=held_out,
        segments=tuple(segments),
        period=period,
        sample_time=float(np.median(np.diff(time))),
        noise_variance=None if steady else noise_variances(recording),
        found=tuple(found),
        held=held_channels(recording, segments),
    )


def held_channels(recording: Recording, windows: list[Window]) -> dict[str, Held]:
    """The outputs held at a range's end inside ``windows``, with the share held there.

    :func:`held_limits` of each output of ``recording``; one held outside the windows only
    (a gauge pressure at zero while idle) is left out.
    """
    inside = np.zeros(recording.time.size, dtype=bool)
    for window in windows:
        inside |= (recording.time >= window.start) & (recording.time < window.end)
    found = {}
    for key, values in recording.measured().items():
        held = held_limits(np.asarray(values, dtype=float)) if values is not None else None
        if held is not None:
            part = np.asarray(values, dtype=float)[inside]
            share = float(np.mean((part <= held.low) | (part >= held.high))) if part.size else 0
            if share > 0.0:
                found[key] = held._replace(share=share)
    return found


def _usable(segment: Segment) -> bool:
    """A segment that is a window beside the steady ones (see the module docstring)."""
    if segment.steady:
        return False
    if segment.kind == "ramp":
        return segment.duration >= SLOW_RAMP_S
    return segment.kind in ("pulsing", "sweep", "modulated")


def _window(segment: Segment, mean: float, index: int, first_time: float) -> Window:
    """The window of a segment that is not steady pulsing."""
    period = 0.0
    if segment.kind == "pulsing":
        period = 1.0 / float(segment.descriptors["frequency_hz"])
    lead = min(segment.t_start - first_time, LEAD_IN_S)
    return Window(
        segment.t_start,
        segment.t_end,
        mean,
        index,
        kind=segment.kind,
        lead_in=lead,
        capped=False,
        period=period,
    )


def split(segments: list[Window]) -> tuple[tuple[Window, ...], tuple[Window, ...]]:
    """Training and held-out windows, within each segment kind (the module docstring)."""
    train: list[Window] = []
    held_out: list[Window] = []
    ramps = [w for w in segments if w.kind == "ramp"]
    later = int(round(len(ramps) * HELD_OUT_SHARE)) if len(ramps) >= LATER_RAMPS else 0
    held_ramps = ramps[len(ramps) - later :] if later else []
    for window in segments:
        if window in held_ramps:
            held_out.append(window)
            continue
        if window.kind == "ramp" and later:
            train.append(window)
            continue
        if window.period > 0.0:  # pulsing: whole cycles of its own period
            cycles = int(round((window.end - window.start) / window.period))
            kept = max(cycles - max(int(round(cycles * HELD_OUT_SHARE)), 1), 1)
            cut = window.start + kept * window.period
        else:  # a sweep, a modulated train, a ramp of a lone pair: its last share in time
            cut = window.start + (1.0 - HELD_OUT_SHARE) * (window.end - window.start)
        train.append(replace(window, end=cut))
        # steady pulsing keeps its preroll; the others carry their history on
        lead = (
            window.lead_in
            if window.capped
            else min(window.lead_in + cut - window.start, LEAD_IN_S)
        )
        held_out.append(replace(window, start=cut, lead_in=lead))
    return tuple(train), tuple(held_out)


def zero_stability(channel: str) -> float:
    """How far (the channel's units) its transducer's zero may wander in a recording.

    ``ZERO_STABILITY`` of the channel's full scale (:data:`SENSORS`).
    """
    sensor = SENSORS[channel]
    return ZERO_STABILITY * (sensor.high - sensor.low)


def read_as_measured(
    predicted: FloatArray, measured: FloatArray, window: Window, channel: str
) -> FloatArray:
    """``predicted`` (..., n) on ``measured``'s (n) zero over ``window``.

    For ``p_b`` over a kind in ``ZERO_LEVELLED_KINDS`` the prediction is shifted by the mean
    of ``measured - predicted`` along the last axis (each row apart), clipped to the zero's
    wander ``ZERO_STABILITY`` of the channel's full scale (:data:`SENSORS`); other channels
    and kinds are returned as they are.
    """
    if window.kind not in ZERO_LEVELLED_KINDS or measured.size == 0 or channel != "p_b":
        return predicted
    bound = zero_stability(channel)
    offset = np.clip(np.mean(measured - predicted, axis=-1, keepdims=True), -bound, bound)
    return np.asarray(predicted + offset, dtype=float)


def read_where_held(outputs: FloatArray, held: dict[str, Held], rate: float) -> FloatArray:
    """Simulated outputs (..., 3, n) read through the ends a held channel reached.

    Each channel in ``held`` is cut at its ends, and the cut is conditioned as the measured
    channel was (the seed's 30 Hz zero-phase low-pass, :func:`signals.lowpass`): the measured
    channel, filtered after its cut, rounds the cut's corners, while the prediction is of the
    conditioned input and needs no second filter where it is not cut. Other channels are
    returned as they are.
    """
    read = np.array(outputs, dtype=float)
    for c, key in enumerate(OUTPUT_CHANNELS):
        limits = held.get(key)
        if limits is None or read.shape[-1] < 32:
            continue
        uncut = read[..., c, :]
        cut = np.clip(uncut, limits.low, limits.high) - uncut
        read[..., c, :] = uncut + np.apply_along_axis(signals.lowpass, -1, cut, rate)
    return read


def noise_variances(recording: Recording) -> dict[str, float]:
    """Each output's noise variance after the conditioning (30 Hz low-pass), in its unit^2.

    From its raw samples above ``NOISE_BAND_HZ`` (white noise: the same density over the
    whole band). The share of a white noise's variance the conditioning keeps is measured on
    a seeded white noise of the recording's length and rate. Empty when the rate leaves no
    band above ``NOISE_BAND_HZ``.
    """
    rate = recording.sample_rate
    nyquist = 0.5 * rate
    if nyquist <= 1.5 * NOISE_BAND_HZ:
        return {}
    white = np.random.default_rng(0).standard_normal(recording.time.size)
    kept = float(np.var(signals.lowpass(white, rate)))
    band = float(np.var(_highpass(white, rate)))
    result = {}
    for key, value in recording.measured().items():
        if value is None:
            continue
        high = float(np.var(_highpass(value, rate)))
        result[key] = high / max(band, 1e-30) * kept
    return result


def _highpass(values: FloatArray, rate: float) -> FloatArray:
    """Zero-phase Butterworth high-pass above ``NOISE_BAND_HZ`` (third order)."""
    from scipy import signal as sps  # type: ignore[import-untyped]

    sos = sps.butter(3, NOISE_BAND_HZ, btype="highpass", fs=rate, output="sos")
    filtered: FloatArray = np.asarray(sps.sosfiltfilt(sos, values), dtype=np.float64)
    return filtered
