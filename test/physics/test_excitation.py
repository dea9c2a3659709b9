"""The seed's excitation: one pulsing schedule, ramp then pulsing per maximum pressure."""

from __future__ import annotations

import numpy as np
import pytest

from brake_hil.physics.excitation import (
    DEFAULT_SCHEDULE,
    SEED_MAX_PRESSURES,
    PulsingSchedule,
    pulsing_profile,
)


def test_schedule_segments_ramp_from_the_previous_mean_to_their_own() -> None:
    schedule = PulsingSchedule(SEED_MAX_PRESSURES, amplitude_fraction=0.2)
    starts = [segment.start for segment in schedule.segments]
    means = [segment.mean for segment in schedule.segments]
    assert starts == [0.0, *means[:-1]]
    for segment, maximum in zip(schedule.segments, SEED_MAX_PRESSURES):
        assert segment.amplitude == pytest.approx(0.2 * maximum)
        assert segment.mean + segment.amplitude == pytest.approx(maximum)


def test_profile_pulses_up_to_each_maximum_at_the_pulsing_frequency() -> None:
    schedule = PulsingSchedule((1.2e6, 2.5e6), ramp_s=0.5, pulsing_s=2.0, pulsing_hz=8.0)
    time, pressure = schedule.profile()
    assert time.size == pressure.size == schedule.samples == 2 * (500 + 2000)
    assert np.all(np.diff(time) == pytest.approx(1e-3))
    assert pressure[0] == 0.0
    for index, segment in enumerate(schedule.segments):
        start = index * 2500
        ramp_end = pressure[start + 499]
        assert ramp_end == pytest.approx(segment.mean, rel=1e-4)
        pulsing = pressure[start + 500 : start + 2500] - segment.mean
        assert np.max(pulsing) == pytest.approx(segment.amplitude, rel=1e-3)
        rising = np.flatnonzero((pulsing[:-1] < 0.0) & (pulsing[1:] >= 0.0))
        assert np.diff(rising) == pytest.approx(1000 / 8.0, abs=1)


def test_pulsing_profile_is_the_profile_of_its_schedule() -> None:
    time, pressure = pulsing_profile((1.4e6, 0.8e6), 2000.0, 0.3, 1.1, 6.5, 0.25)
    schedule = PulsingSchedule((1.4e6, 0.8e6), 0.3, 1.1, 6.5, 0.25, 2000.0)
    expected_time, expected_pressure = schedule.profile()
    assert time.tobytes() == expected_time.tobytes()
    assert pressure.tobytes() == expected_pressure.tobytes()
    assert pulsing_profile()[1].tobytes() == DEFAULT_SCHEDULE.profile()[1].tobytes()


def test_scaled_and_resampled_schedules_keep_the_rest() -> None:
    schedule = PulsingSchedule((1.0e6, 2.0e6), ramp_s=0.2)
    scaled = schedule.scaled(4.0).at_rate(10_000.0)
    assert scaled.max_pressures == (4.0e6, 8.0e6)
    assert scaled.ramp_samples == 2000 and scaled.ramp_s == schedule.ramp_s
    assert [s.mean for s in scaled.segments] == pytest.approx(
        [4.0 * s.mean for s in schedule.segments]
    )
    assert schedule.levels_mpa == "1.00, 2.00"
    assert PulsingSchedule((1_000_000,)).max_pressures == (1.0e6,)  # floats
