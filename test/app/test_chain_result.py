"""The chain's verdict: sample counts, steady cycles, real time, loop timing (no nodes: the
figures as the nodes leave them)."""

from __future__ import annotations

from pathlib import Path

from brake_hil.app.chain import ChainResult, bag_bytes, wait_until_quiet
from brake_hil.app.chain_result import (
    LOOP_LIMITS,
    judge_cycles,
    judge_loop,
    judge_real_time,
    judge_samples,
    verdict,
)
from brake_hil.nodes.settings import CaliperModelSettings
from brake_hil.runtime.timing import LATE_TICK_NS


def _result(
    published: int, predicted: int, inputs: int, recorded: int, expected: int | None
) -> ChainResult:
    return ChainResult(
        out_dir=Path("."),
        source={"published": published},
        model={"counters": {"predictions": predicted}},
        bag=Path("bag"),
        check={"inputs": inputs, "predictions": recorded},
        expected=expected,
    )


def test_a_whole_run_is_ok() -> None:
    ok, line = _result(18_000, 18_000, 18_000, 18_000, 18_000).sample_losses()
    assert ok
    assert line.startswith("every sample predicted and recorded: 18000 samples published")


def test_a_source_stopped_before_the_end_of_its_run_is_not_ok() -> None:
    # a starved source that the launcher's timeout stopped: what it sent was all predicted and
    # recorded, but a third of the recording was never replayed
    ok, line = _result(12_125, 12_125, 12_125, 12_125, 18_000).sample_losses()
    assert not ok
    assert line.startswith("the run was cut short: 12125 of the run's 18000 samples published")


def test_lost_samples_are_counted() -> None:
    ok, line = _result(18_000, 18_000, 15_544, 15_961, 18_000).sample_losses()
    assert not ok
    assert line.startswith("samples were lost")
    assert "(4495 lost)" in line


def test_no_summary_is_not_ok() -> None:
    result = ChainResult(out_dir=Path("."), model={"counters": {"predictions": 1}})
    ok, line = result.sample_losses()
    assert not ok and "cannot tell" in line


def test_a_bag_that_stops_growing_is_quiet(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    assert bag_bytes(bag) == 0
    bag.mkdir()
    (bag / "a.mcap").write_bytes(b"x" * 10)
    assert bag_bytes(bag) == 10
    assert wait_until_quiet(bag, quiet_s=0.2, timeout_s=5.0, poll_s=0.02)


def test_a_bag_that_keeps_growing_is_not_quiet(tmp_path: Path) -> None:
    import threading

    bag = tmp_path / "bag"
    bag.mkdir()
    stop = threading.Event()

    def grow() -> None:
        with (bag / "a.mcap").open("ab") as stream:
            while not stop.wait(0.02):
                stream.write(b"x")
                stream.flush()

    writer = threading.Thread(target=grow)
    writer.start()
    try:
        assert not wait_until_quiet(bag, quiet_s=1.0, timeout_s=2.5, poll_s=0.02)
    finally:
        stop.set()
        writer.join()


# --------------------------------------------------------------------------- the verdict

EXPECTED = {"p_b": 48, "F_k": 47, "x_c": 45}


def _judged(
    scored: dict[str, int] | None = None,
    replay_lag_s: float = 0.01,
    model_lag_s: float = 0.002,
    period_p99_us: float = 60.0,
    latency_p99_us: float = 300.0,
) -> tuple[int, list[str], list[str]]:
    return verdict(
        [
            judge_samples(True, "every sample predicted and recorded: 18000 samples published"),
            judge_cycles(EXPECTED if scored is None else scored, EXPECTED),
            judge_real_time(18.0, replay_lag_s, model_lag_s),
            judge_loop(period_p99_us, latency_p99_us),
        ],
        {},
    )


def test_a_run_that_holds_every_judgement_exits_0() -> None:
    status, held, failed = _judged()
    assert status == 0 and failed == []
    assert held[1] == "steady cycles scored: p_b 48 of 48, F_k 47 of 47, x_c 45 of 45"
    assert held[2].startswith("real time kept: the replay ran up to 10.0 ms behind")
    assert held[3].startswith("loop timing OK: period error p99 60 us (OK")


def test_too_few_cycles_on_one_channel_fail_with_the_counts_and_why() -> None:
    status, _, failed = _judged({"p_b": 48, "F_k": 16, "x_c": 45})
    assert status == 1
    assert failed == [
        "too few steady cycles scored (F_k under 90% of those the recording holds): "
        "p_b 48 of 48, F_k 16 of 47, x_c 45 of 45"
    ]
    judgement = judge_cycles(
        {"p_b": 0}, {"p_b": 48}, {"p_b": {"behind": 23162, "mismatch": 0, "end": 3}}
    )
    assert judgement.level == 2
    assert judgement.line.endswith(
        "; p_b 23165 unpaired (23162 no partner within the horizon, "
        "3 partner still missing at the end)"
    )


def test_a_run_that_fell_seconds_behind_is_not_real_time() -> None:
    status, _, failed = _judged(replay_lag_s=7.9, model_lag_s=6.0)
    assert status == 1
    assert failed == [
        "not a real-time run: the replay ran up to 7.90 s behind its 18.0 s schedule; "
        "the model ran up to 6.00 s behind its input"
    ]


def test_loop_timing_warn_holds_and_error_fails() -> None:
    status, held, _ = _judged(period_p99_us=7_456.0)
    assert status == 0 and held[3].startswith("loop timing WARN: period error p99 7.5 ms (WARN")
    status, _, failed = _judged(latency_p99_us=15_190_900.0)
    assert status == 1 and failed[0].startswith("loop timing ERROR: ")
    assert "latency p99 15.19 s (ERROR" in failed[0]


def test_nothing_compared_is_never_a_clean_pass() -> None:
    # the run of the report: every sample predicted and recorded, no cycle scored
    status, _, failed = _judged({"p_b": 0, "F_k": 0, "x_c": 0})
    assert status == 1 and failed[0].startswith("too few steady cycles scored (p_b, F_k, x_c")
    assert judge_cycles(None, EXPECTED).level == 2
    assert judge_cycles({"p_b": 0}, None).level == 2
    no_cycle = judge_cycles({"p_b": 0}, {"p_b": 0})
    assert no_cycle.level == 1 and no_cycle.line.startswith("nothing compared")


def test_a_node_that_failed_fails_the_run() -> None:
    status, _, failed = verdict([judge_samples(True, "all")], {"recorder": 1})
    assert status == 1 and failed == ["nodes exited with errors: {'recorder': 1}"]


def test_the_result_is_judged_from_what_the_nodes_left() -> None:
    ok = {"median_us": 20.0, "p99_us": 80.0, "max_us": 900.0, "ceiling_us": 1e8}
    result = ChainResult(
        out_dir=Path("."),
        source={"published": 100, "period_error": {**ok, "max_us": 6e6}},
        model={"counters": {"predictions": 100}, "period_error": ok, "latency": ok},
        comparator={
            "window_cycles": 10,
            "metrics": {c: {"cycles": 0, "unpaired_reasons": {}} for c in EXPECTED},
        },
        expected=100,
        expected_cycles=EXPECTED,
        schedule_s=18.0,
    )
    status, held, failed = result.verdict()
    assert status == 1
    assert held[0].startswith("every sample predicted and recorded")
    assert [line.split(":")[0] for line in failed] == [
        "too few steady cycles scored (p_b, F_k, x_c under 90% of those the recording holds)",
        "not a real-time run",
    ]


def test_the_loop_limits_are_the_caliper_models_own_levels() -> None:
    settings = CaliperModelSettings()
    assert LOOP_LIMITS.latency_warn_us == settings.input_late_ms * 1000
    assert LOOP_LIMITS.latency_error_us == settings.input_silent_ms * 1000
    assert LOOP_LIMITS.period_error_us == settings.input_silent_ms * 1000
    assert LOOP_LIMITS.period_warn_us == LATE_TICK_NS / 1000


def test_a_late_loop_says_how_busy_the_machine_was() -> None:
    late = judge_loop(13_400.0, 300.0, load=(3.1, 2))
    assert late.line.endswith(
        "the machine's load average was 3.1 on 2 cores, the chain's own nodes included (busy: "
        "other work took the CPU the loop needed)"
    )
    assert judge_loop(13_400.0, 300.0, load=(0.6, 2)).line.endswith("(not busy)")
    assert "load average" not in judge_loop(60.0, 300.0, load=(3.1, 2)).line  # OK: no word
