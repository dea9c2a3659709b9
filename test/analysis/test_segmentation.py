"""The segmenter on synthetic chains: every kind found, with its times and descriptors."""

from __future__ import annotations

import numpy as np
import pytest

from brake_hil.analysis import signals
from brake_hil.analysis.segmentation import Segment, find_segments
from test.analysis.chains import RATE, procedure

TOLERANCE_S = {  # how far a found boundary may lie from the built one (s)
    "step": 0.05,
    "ramp": 0.15,
    "hold": 0.35,
    "idle": 0.35,
    "modulated": 0.3,
    "sweep": 1.0,
}
"""A sweep that begins where the rig's 5 Hz pulsing ends starts where the steady pulsing
(today's ``steady_segments``, the authority there) lets it: a log sweep leaves 5 Hz slowly,
so up to a second late; steps are sharp."""


def _found(segments: list[Segment], kind: str, start: float, end: float) -> Segment:
    """The found segment of ``kind`` overlapping ``[start, end]`` most."""
    overlaps = [(min(s.t_end, end) - max(s.t_start, start), s) for s in segments if s.kind == kind]
    overlaps = [(o, s) for o, s in overlaps if o > 0]
    assert overlaps, (
        f"no {kind} found in {start}-{end} s: {[(s.kind, s.t_start) for s in segments]}"
    )
    return max(overlaps, key=lambda pair: pair[0])[1]


@pytest.mark.parametrize(("seed", "law"), [(1, "linear"), (7, "log")])
def test_a_procedure_is_split_into_every_kind_it_holds(seed: int, law: str) -> None:
    time, pressure, expected = procedure(seed, law)
    segments = find_segments(time, signals.lowpass(pressure, RATE), RATE, 5.0)
    for kind, start, end, info in expected:
        found = _found(segments, kind, start, end)
        if kind == "pulsing":  # the steady pulsing of today, unchanged: settles 1 s first
            assert found.steady and abs(found.t_start - start) < 0.25
            assert found.descriptors["frequency_hz"] == 5.0
            continue
        tolerance = TOLERANCE_S[kind]
        assert abs(found.t_start - start) <= tolerance, (kind, start, found)
        assert abs(found.t_end - end) <= tolerance, (kind, end, found)
        for key, value in info.items():
            if isinstance(value, str):
                assert found.descriptors[key] == value, (kind, key, found)
            elif key in ("f0_hz",):  # the sweep's start is cut by the pulsing's tail
                assert value <= float(found.descriptors[key]) <= value * 1.25, (kind, key, found)
            else:
                assert float(found.descriptors[key]) == pytest.approx(value, rel=0.03), (
                    kind,
                    key,
                    found,
                )
    kinds = [s.kind for s in segments]
    assert kinds.count("sweep") == 1 and kinds.count("modulated") == 1
    assert kinds.count("pulsing") == 1  # the settling before it is no segment of its own
    starts = [s.t_start for s in segments]
    assert starts == sorted(starts)
    assert all(b.t_start >= a.t_end - 1e-6 for a, b in zip(segments, segments[1:]))


@pytest.mark.parametrize("hz", [0.8, 12.0, 22.0])
def test_pulsing_at_another_frequency_is_pulsing_at_that_frequency(hz: float) -> None:
    rng = np.random.default_rng(3)
    time = np.arange(int(12 * RATE)) / RATE
    pressure = 1.2e6 + 0.3e6 * np.sin(2 * np.pi * hz * time) + rng.normal(0, 1.5e3, time.size)
    segments = find_segments(time, signals.lowpass(pressure, RATE), RATE, 5.0)
    pulsing = [s for s in segments if s.kind == "pulsing"]
    assert len(pulsing) == 1 and not pulsing[0].steady
    assert float(pulsing[0].descriptors["frequency_hz"]) == pytest.approx(hz, rel=0.02)
    assert pulsing[0].duration > 10.0


def test_a_square_train_of_pressure_dumps_is_modulated_not_pulsing() -> None:
    time = np.arange(int(6 * RATE)) / RATE
    phase = (time * 8.0) % 1.0
    pressure = 2.0e6 - 0.8e6 * (phase < 0.2)  # dumps 20 % of each 125 ms
    segments = find_segments(time, signals.lowpass(pressure, RATE), RATE, 5.0)
    assert [s.kind for s in segments] == ["modulated"]


def test_noise_alone_is_idle() -> None:
    rng = np.random.default_rng(5)
    time = np.arange(int(4 * RATE)) / RATE
    pressure = rng.normal(0.0, 1.5e3, time.size)
    segments = find_segments(time, signals.lowpass(pressure, RATE), RATE, 5.0)
    assert [s.kind for s in segments] == ["idle"]
