"""The chain's one-line verdict on its sample counts (no nodes: counts as the nodes leave them)."""

from __future__ import annotations

from pathlib import Path

from brake_hil.app.chain import ChainResult, bag_bytes, wait_until_quiet


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
