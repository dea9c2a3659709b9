"""The real-time loop's timing and catch-up logic, with fake clocks (no ROS, no sleeping)."""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
import pytest

from brake_hil.live.model_file import load_model
from brake_hil.runtime import CatchUpRunner as Runner
from brake_hil.runtime import (
    DeadlineLoop,
    Histogram,
    HoldMode,
    InputState,
    LoopStatistics,
    PhaseLock,
    Sample,
    Tick,
    loop_span_ns,
    replay_deadlines,
    sleep_until,
)
from test.conftest import CONFIG

MS = 1_000_000


class FakeTime:
    """A monotonic clock (ns) that only moves when slept on or when told to."""

    def __init__(self, start: int = 10 * MS) -> None:
        self.now = start
        self.sleeps: list[float] = []

    def clock(self) -> int:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += max(1_000, round(seconds * 1e9))  # each spin turn costs 1 us


# --------------------------------------------------------------------------- histogram


def test_histogram_quantiles_are_those_of_the_data_to_the_microsecond() -> None:
    histogram = Histogram(limit_us=1000)
    values = np.random.default_rng(1).integers(0, 900_000, 10_000)
    for value in values:
        histogram.add(int(value))
    for q in (0.5, 0.99, 0.999):
        assert histogram.quantile_us(q) == pytest.approx(np.quantile(values, q) / 1e3, abs=1.5)
    assert histogram.summary().max_us == values.max() / 1e3
    assert histogram.count_at_least(500 * 1000) == pytest.approx(np.sum(values >= 500_000), abs=20)


def test_histogram_overflow_reports_the_exact_maximum() -> None:
    histogram = Histogram(limit_us=10)
    for value in (1_000, 2_000, 5_000_000):
        histogram.add(value)
    assert histogram.quantile_us(1.0) == 5_000.0
    assert histogram.summary().max_us == 5_000.0
    assert np.isnan(Histogram().summary().median_us)


def test_statistics_window_restarts_while_the_run_total_keeps_counting() -> None:
    statistics = LoopStatistics()
    statistics.add("latency", 300_000)
    assert statistics.take_window()["latency"].samples == 1
    statistics.add("latency", 400_000)
    assert statistics.take_window()["latency"].samples == 1
    assert statistics.total["latency"].count == 2


# --------------------------------------------------------------------------- sleeping


def test_sleep_until_sleeps_to_the_spin_margin_then_spins_to_the_deadline() -> None:
    fake = FakeTime(start=0)
    woke = sleep_until(1 * MS, spin_ns=200_000, clock=fake.clock, sleep=fake.sleep)
    assert fake.sleeps[0] == pytest.approx(0.8e-3)
    assert all(s == 0 for s in fake.sleeps[1:])  # spinning yields with sleep(0)
    assert 1 * MS <= woke < 1 * MS + 2_000


def test_sleep_until_returns_at_once_when_the_deadline_has_passed() -> None:
    fake = FakeTime(start=5 * MS)
    assert sleep_until(1 * MS, 200_000, fake.clock, fake.sleep) == 5 * MS
    assert fake.sleeps == []


# --------------------------------------------------------------------------- the loop


def _loop(fake: FakeTime, work_ns: list[int], **kwargs: object) -> tuple[DeadlineLoop, list[Tick]]:
    ticks: list[Tick] = []

    def tick(t: Tick) -> None:
        ticks.append(t)
        fake.now += work_ns[(len(ticks) - 1) % len(work_ns)]

    loop = DeadlineLoop(tick, 1 * MS, 100_000, clock=fake.clock, sleep=fake.sleep, **kwargs)  # type: ignore[arg-type]
    return loop, ticks


def test_deadlines_are_absolute_so_the_loop_does_not_drift() -> None:
    fake = FakeTime(start=0)
    loop, ticks = _loop(fake, [50_000, 700_000, 10_000])  # uneven work inside the period
    loop.run_ticks(1000, first_deadline_ns=1 * MS)
    deadlines = [t.deadline_ns for t in ticks]
    assert deadlines == [(k + 1) * MS for k in range(1000)]
    assert all(t.wake_ns - t.deadline_ns < 2_000 for t in ticks)
    assert loop.statistics.counters.overruns == 0


def test_a_late_wake_up_skips_the_passed_slots_and_keeps_the_grid() -> None:
    fake = FakeTime(start=0)
    loop, ticks = _loop(fake, [10_000, 3_500_000, 10_000, 10_000])  # tick 2 runs 3.5 periods
    loop.run_ticks(4, first_deadline_ns=1 * MS)
    # tick 3 wakes 2.5 periods late: it runs (late), the slots at 4 and 5 ms are skipped
    assert [t.deadline_ns for t in ticks] == [1 * MS, 2 * MS, 3 * MS, 6 * MS]
    assert [t.slot for t in ticks] == [0, 1, 2, 5] and ticks[2].skipped == 2
    counters = loop.statistics.counters
    assert counters.overruns == 1 and counters.ticks_skipped == 2 and counters.late_ticks == 1
    late = FakeTime(start=0)
    loop, ticks = _loop(late, [10_000])
    late.now = 3_400_000  # the first wake-up comes 2.4 periods late
    loop.run_ticks(2, first_deadline_ns=1 * MS)
    assert ticks[0].skipped == 2 and ticks[1].deadline_ns == 4 * MS
    assert loop.statistics.counters.late_ticks == 1
    assert loop.statistics.total["period_error"].max_ns == 2_400_000


def test_a_phase_request_moves_the_grid_once() -> None:
    fake = FakeTime(start=0)
    loop, ticks = _loop(fake, [10_000])
    loop.request_phase(300_000)
    loop.run_ticks(4, first_deadline_ns=1 * MS)
    assert [t.deadline_ns for t in ticks] == [1 * MS, 1_300_000, 2_300_000, 3_300_000]
    assert loop.phase_ns == 300_000 and loop.statistics.counters.phase_shifts == 1


def test_the_loop_thread_stops_and_keeps_an_error_of_its_tick() -> None:
    errors: list[BaseException] = []

    def tick(t: Tick) -> None:
        if t.slot >= 3:  # a late first tick skips slots (busy runner): not == 3
            raise RuntimeError("boom")

    loop = DeadlineLoop(tick, 1 * MS, 100_000, on_error=errors.append)
    loop.start()
    for _ in range(200):
        if not loop.running:
            break
        time.sleep(0.01)
    loop.stop()
    assert isinstance(loop.error, RuntimeError) and errors == [loop.error]


@pytest.mark.parametrize("fifo", [False, True])
def test_the_loop_spins_before_its_deadlines_only_under_sched_fifo(
    fifo: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    # At normal priority a spin buys no timing and takes the CPU the loop's feeders need.
    from brake_hil.runtime import deadline_loop

    monkeypatch.setattr(deadline_loop, "set_realtime_priority", lambda priority: fifo)
    idle_turns: list[int] = []
    ticks: list[int] = []
    loop = DeadlineLoop(
        lambda t: ticks.append(t.slot), 1 * MS, 500_000, idle=lambda: idle_turns.append(1)
    )
    loop.start()
    for _ in range(500):
        if len(ticks) >= 20:
            break
        time.sleep(0.01)
    loop.stop()
    assert len(ticks) >= 20 and loop.realtime is fifo
    assert loop.spin_ns == (500_000 if fifo else 0)
    assert (len(idle_turns) > 0) is fifo


def test_a_held_loop_ticks_only_when_driven_counts_alike_and_takes_over_on_release() -> None:
    ticks: list[Tick] = []
    loop = DeadlineLoop(ticks.append, 1 * MS, 100_000)
    loop.start(held=True)
    time.sleep(0.05)  # a held loop's thread runs no tick of its own
    assert loop.running and loop.held and ticks == []
    now = time.monotonic_ns()
    for k in range(5):  # the driver's own deadlines, one woken 2 ms late
        assert loop.drive(now + k * MS, now + k * MS + (2 * MS if k == 3 else 10_000))
    assert [t.slot for t in ticks] == [0, 1, 2, 3, 4] and loop.driven_ticks == 5
    assert [t.deadline_ns - now for t in ticks] == [k * MS for k in range(5)]
    counters = loop.statistics.counters
    assert counters.ticks == 5 and counters.late_ticks == 1
    assert loop.statistics.total["period_error"].max_ns == 2 * MS
    released = time.monotonic_ns()
    loop.release()
    assert not loop.held and not loop.drive(now, now)  # released: the driver is ignored
    deadline = time.monotonic() + 30.0  # generous: a busy runner
    while len(ticks) < 10 and time.monotonic() < deadline:
        time.sleep(0.01)
    loop.stop()
    assert len(ticks) >= 10 and loop.error is None
    own = ticks[5:]
    assert own[0].slot == 5 and all(b.slot > a.slot for a, b in zip(own, own[1:]))
    assert own[0].deadline_ns >= released + 1 * MS  # its own grid, from the release on


def test_a_driven_tick_that_fails_stops_the_loop_and_keeps_the_error() -> None:
    errors: list[BaseException] = []

    def tick(t: Tick) -> None:
        if t.slot == 1:
            raise RuntimeError("boom")

    loop = DeadlineLoop(tick, 1 * MS, 100_000, on_error=errors.append)
    loop.start(held=True)
    now = time.monotonic_ns()
    assert loop.drive(now, now) and not loop.drive(now + MS, now + MS)
    assert not loop.drive(now + 2 * MS, now + 2 * MS)  # stopped: nothing runs any more
    loop.stop()
    assert not loop.running and isinstance(loop.error, RuntimeError) and errors == [loop.error]


def test_a_failure_while_held_stops_the_loop_and_keeps_the_error() -> None:
    errors: list[BaseException] = []

    def subscribe() -> None:
        raise RuntimeError("no context")

    loop = DeadlineLoop(
        lambda t: None, 1 * MS, 100_000, on_error=errors.append, while_held=subscribe
    )
    loop.start(held=True)
    deadline = time.monotonic() + 30.0
    while loop.running and time.monotonic() < deadline:
        time.sleep(0.01)
    assert not loop.running and isinstance(loop.error, RuntimeError) and errors == [loop.error]


def test_a_held_loop_stops_without_a_release() -> None:
    loop = DeadlineLoop(lambda t: None, 1 * MS, 100_000)
    loop.start(held=True)
    loop.stop()
    assert not loop.running and loop.statistics.counters.ticks == 0


# --------------------------------------------------------------------------- phase lock


@pytest.mark.parametrize("centre_us", [300, 990])  # 990: the arrivals straddle the period edge
def test_phase_lock_places_ticks_just_after_the_arrivals(centre_us: int) -> None:
    rng = np.random.default_rng(2)
    lock = PhaseLock(1 * MS, margin_ns=50_000)
    for k in range(1000):
        lock.observe(k * MS + centre_us * 1000 + int(rng.normal(0, 30_000)))
    phase = lock.propose(None)
    assert phase is not None
    wait = (phase - centre_us * 1000) % MS
    assert 50_000 < wait < 250_000  # after ~99 % of arrivals, well before the next ones
    assert lock.wait_quantile_ns(phase) < 300_000
    assert lock.propose(phase) is None  # already there
    assert lock.propose((phase + 500_000) % MS) is not None


# --------------------------------------------------------------------------- catching up


@pytest.fixture(scope="module")
def model():  # type: ignore[no-untyped-def]
    return load_model(CONFIG / "rig_default.yaml", 1.0e6)


def _pressure(n: int) -> np.ndarray:
    k = np.arange(n)
    return 1.0e6 + 4.0e5 * np.sin(2 * np.pi * 5.0 * k / 1000.0) + 1e3 * np.cos(0.37 * k)


def test_every_sample_is_stepped_once_in_order_and_equals_the_batch_model(model) -> None:  # type: ignore[no-untyped-def]
    pressure = _pressure(600)
    runner = Runner(model.stepper())
    stamps = 1_700_000_000 * 10**9 + np.arange(600) * MS
    predictions = []
    bursts = [1, 0, 3, 1, 7, 0, 0, 2]  # samples arriving per tick, uneven
    k, now = 0, 0
    while k < pressure.size:
        for _ in range(bursts[now % len(bursts)]):
            if k < pressure.size:
                runner.push(Sample(int(stamps[k]), float(pressure[k]), now * MS))
                k += 1
        now += 1
        predictions += runner.tick(now * MS).predictions
    assert [p.stamp_ns for p in predictions] == stamps.tolist()
    live = np.array([p[1:4] for p in predictions])  # p_b, F_k, x_c
    batch = model.batch(pressure).T
    assert np.max(np.abs(live - batch) / np.ptp(batch, axis=0)) < 1e-12
    counters = runner.statistics.counters
    assert counters.samples == counters.predictions == 600
    assert counters.max_per_tick == 7 and counters.caught_up_ticks > 0


def test_input_states_follow_the_silence_and_nothing_is_invented(model) -> None:  # type: ignore[no-untyped-def]
    runner = Runner(model.stepper(), late_after_ns=3 * MS, silent_after_ns=8 * MS)
    assert runner.tick(0).state is InputState.WAITING
    runner.push(Sample(5 * MS, 1e6, 1 * MS))
    result = runner.tick(1 * MS)
    assert result.state is InputState.FRESH and len(result.predictions) == 1
    assert runner.tick(4 * MS).state is InputState.LATE
    silent = runner.tick(9 * MS)
    assert silent.state is InputState.SILENT and silent.state_changed
    assert silent.predictions == [] and runner.statistics.counters.held == 0


def test_stamp_gaps_count_missing_samples_and_are_not_filled(model) -> None:  # type: ignore[no-untyped-def]
    runner = Runner(model.stepper())
    for stamp in (0, 1 * MS, 5 * MS, 5 * MS, 4 * MS, 6 * MS):
        runner.push(Sample(stamp, 1e6, 0))
    predictions = runner.tick(0).predictions
    assert [p.stamp_ns for p in predictions] == [0, 1 * MS, 5 * MS, 6 * MS]  # one per stamp
    assert runner.statistics.counters.missing_samples == 3
    assert runner.statistics.counters.stamps_backwards == 2


def test_a_nonfinite_input_is_not_stepped_and_the_model_holds_its_last_good_state(model) -> None:  # type: ignore[no-untyped-def]
    pressure = _pressure(40)
    clean = Runner(model.stepper())
    faulty = Runner(model.stepper(), restart=model.stepper)
    for k, value in enumerate(pressure):
        clean.push(Sample(k * MS, float(value), 0))
        faulty.push(Sample(k * MS, float("nan") if k in (10, 11) else float(value), 0))
    reference = {p.stamp_ns: p for p in clean.tick(0).predictions}
    predictions = faulty.tick(0).predictions
    counters = faulty.statistics.counters
    assert [p.stamp_ns for p in predictions] == [k * MS for k in range(40) if k not in (10, 11)]
    assert counters.nonfinite_inputs == 2 and counters.missing_samples == 0
    assert faulty.last_nonfinite_stamp_ns == 11 * MS
    assert all(np.isfinite(p[1:4]).all() for p in predictions)
    # Up to the NaN the same; after it the model steps from its last good state and input.
    assert predictions[9] == reference[9 * MS]
    held_model = model.stepper()
    for value in [*pressure[:10], *pressure[12:]]:
        expected = held_model.step(float(value))
    assert predictions[-1][1:4] == tuple(expected)


def test_a_nonfinite_state_is_not_published_and_restarts_from_the_equilibrium(model) -> None:  # type: ignore[no-untyped-def]
    runner = Runner(model.stepper(), restart=model.stepper)
    values = [1.6e6] * 5 + [1.79e308] * 40 + [1.2e6] * 5
    for k, value in enumerate(values):
        runner.push(Sample(k * MS, value, 0))
    predictions = runner.tick(0).predictions
    counters = runner.statistics.counters
    assert counters.nonfinite_states >= 1 and counters.state_resets >= 1
    assert len(predictions) + counters.nonfinite_states == len(values)
    assert all(np.isfinite(p[1:4]).all() for p in predictions)
    stamps = {p.stamp_ns for p in predictions}
    restarted = [k for k in range(1, len(values)) if {k * MS, (k - 1) * MS} & stamps == {k * MS}]
    assert restarted  # the step after a non-finite one starts at the equilibrium of its input
    first = next(p for p in predictions if p.stamp_ns == restarted[0] * MS)
    assert first.bore_pressure == pytest.approx(values[restarted[0]], rel=1e-9)


def test_hold_mode_free_runs_on_the_last_input_and_flags_it(model) -> None:  # type: ignore[no-untyped-def]
    runner = Runner(
        model.stepper(), late_after_ns=3 * MS, silent_after_ns=8 * MS, hold_mode=HoldMode.HOLD
    )
    runner.push(Sample(100 * MS, 1.2e6, 0))
    runner.tick(0)
    assert runner.tick(7 * MS).predictions == []  # late, not yet silent
    held = runner.tick(10 * MS).predictions
    assert len(held) == 10 and all(p.held for p in held)
    assert [p.stamp_ns for p in held] == [(100 + k) * MS for k in range(1, 11)]
    runner.push(Sample(105 * MS, 1.2e6, 11 * MS))  # late: its slot was held already
    runner.push(Sample(111 * MS, 1.3e6, 11 * MS))
    result = runner.tick(11 * MS)
    assert [p.stamp_ns for p in result.predictions] == [111 * MS]
    assert not result.predictions[0].held and result.state is InputState.FRESH
    assert runner.statistics.counters.superseded == 1 and runner.statistics.counters.held == 10


# --------------------------------------------------------------------------- replay pacing


def test_replay_deadlines_follow_the_stamps_at_the_rate_factor() -> None:
    stamps = np.array([0, 1, 2, 4, 5], dtype=np.int64) * MS + 123
    expected = 10 * MS + np.array([0, 500, 1000, 2000, 2500]) * 1000
    np.testing.assert_array_equal(replay_deadlines(stamps, 10 * MS, 2.0), expected)
    assert loop_span_ns(stamps) == 6 * MS
    with pytest.raises(ValueError, match="rate"):
        replay_deadlines(stamps, 0, 0.0)


def test_realtime_regression_and_model_files_import_without_rclpy() -> None:
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('rclpy', 'rosidl_runtime_py', 'rcl_interfaces'):\n"
        "            raise ImportError('blocked: ' + name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "import brake_hil.runtime, brake_hil.app.regress, brake_hil.live.model_file\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
