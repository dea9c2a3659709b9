"""A recording prepared for diagnosis: conditioned signals, steady windows, train/held-out split.

The split keeps the held-out data out of every fit: the last 40 % of every steady segment's
cycles is held out. Every pressure amplitude is then seen in training (the amplitude
dependence is learnt, as the seed learns k_eh per experiment), and every candidate must
predict cycles later in time than any it was fitted on, which is what exposes a drift. (A
held-out middle segment would hide a drift: a calibration fitted to both ends is right in the
middle.)

Signals are conditioned as the seed does (30 Hz zero-phase low-pass) and decimated to
``DIAGNOSIS_RATE`` for the fits (the 5 Hz excitation's first five harmonics stay far below
its Nyquist frequency).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline  # type: ignore[import-untyped]

from brake_hil.analysis import signals
from brake_hil.analysis.comparison import conditioned_channels, steady_windows
from brake_hil.analysis.recording import Recording
from brake_hil.physics.rig import Rig
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray

DIAGNOSIS_RATE = 500.0
"""Sample rate (Hz) of the signals the diagnosis fits."""
HELD_OUT_SHARE = 0.4


@dataclass(frozen=True)
class Window:
    """A span of whole cycles (s) and the mean master-cylinder pressure over it (Pa)."""

    start: float
    end: float
    mean_pressure: float
    segment: int  # index of the steady segment it belongs to


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

    def mask(self, windows: tuple[Window, ...]) -> FloatArray:
        """Boolean mask of the samples inside ``windows``."""
        inside = np.zeros(self.time.size, dtype=bool)
        for window in windows:
            inside |= (self.time >= window.start - 1e-9) & (self.time < window.end - 1e-9)
        return inside

    def scale(self) -> dict[str, float]:
        """Peak-to-peak of each measured channel over the steady segments (normaliser)."""
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
        """
        per_period = self.period / self.sample_time
        lag = int(round(per_period))
        whole = abs(per_period - lag) < 1e-6
        scale = self.scale()
        costs = []
        for key, value in self.measured.items():
            differences = []
            for window in self.segments:
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


def prepare(recording: Recording, rig: Rig) -> Dataset:
    """Condition, decimate and split a recording (see the module docstring)."""
    filtered = conditioned_channels(recording)
    windows = steady_windows(recording, filtered["p_i"], rig)
    step = max(int(round(recording.sample_rate / DIAGNOSIS_RATE)), 1)
    time = recording.time[::step]
    period = 1.0 / rig.excitation_hz
    segments = []
    for index, (start, end) in enumerate(windows):
        part = signals.segment_slice(recording.time, start, end)
        segments.append(Window(start, end, float(np.mean(filtered["p_i"][part])), index))
    train: list[Window] = []
    held_out: list[Window] = []
    for segment in segments:
        cycles = int(round((segment.end - segment.start) / period))
        kept = max(cycles - max(int(round(cycles * HELD_OUT_SHARE)), 1), 1)
        cut = segment.start + kept * period
        train.append(Window(segment.start, cut, segment.mean_pressure, segment.segment))
        held_out.append(Window(cut, segment.end, segment.mean_pressure, segment.segment))
    return Dataset(
        name=str(recording.path),
        time=time,
        pressure=filtered["p_i"][::step],
        measured={key: filtered[key][::step] for key in OUTPUT_CHANNELS},
        train=tuple(train),
        held_out=tuple(held_out),
        segments=tuple(segments),
        period=period,
        sample_time=float(np.median(np.diff(time))),
    )
