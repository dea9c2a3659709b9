"""``--jobs``, ``--scheduler``, ``--serial`` of the commands over many recordings, and the bar
that counts their recordings."""

from __future__ import annotations

import io

import pytest

from brake_hil.app.parallel import Workers
from brake_hil.cli.parser import build_parser
from brake_hil.cli.progress import fleet_bar
from brake_hil.cli.workers import SCHEDULER_VARIABLE, workers_from_args
from brake_hil.errors import BrakeHilError

COMMANDS = {
    "regress": ["regress", "bag", "--baseline", "b.json"],
    "benchmark": ["benchmark", "dir"],
    "cases": ["cases", "--out", "dir"],
}
ADDRESS = "tcp://127.0.0.1:8786"


def workers(argv: list[str], environ: dict[str, str] | None = None) -> Workers:
    return workers_from_args(build_parser().parse_args(argv), environ or {})


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_each_command_takes_jobs_a_scheduler_or_serial(command: str) -> None:
    argv = COMMANDS[command]
    assert workers(argv) == Workers()  # a LocalCluster, one worker per core
    assert workers([*argv, "--jobs", "3"]) == Workers(jobs=3)
    assert workers([*argv, "--scheduler", ADDRESS]) == Workers(scheduler=ADDRESS)
    assert workers([*argv, "--serial"]) == Workers(serial=True)


def test_the_scheduler_defaults_to_the_environment_unless_an_option_says_otherwise() -> None:
    argv = COMMANDS["regress"]
    environ = {SCHEDULER_VARIABLE: ADDRESS}
    assert workers(argv, environ) == Workers(scheduler=ADDRESS)
    assert workers([*argv, "--scheduler", "tcp://10.0.0.5:8786"], environ).scheduler == (
        "tcp://10.0.0.5:8786"
    )
    assert workers([*argv, "--jobs", "2"], environ) == Workers(jobs=2)
    assert workers([*argv, "--serial"], environ) == Workers(serial=True)
    assert workers(argv, {SCHEDULER_VARIABLE: " "}) == Workers()


@pytest.mark.parametrize(
    "options", [["--jobs", "2", "--serial"], ["--jobs", "2", "--scheduler", ADDRESS]]
)
def test_the_options_exclude_each_other(
    options: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as end:
        build_parser().parse_args([*COMMANDS["cases"], *options])
    assert end.value.code == 2
    assert "not allowed with argument" in capsys.readouterr().err


def test_no_worker_process_is_refused_at_the_door() -> None:
    with pytest.raises(BrakeHilError, match="--jobs 0"):
        workers([*COMMANDS["benchmark"], "--jobs", "0"])


def test_the_fleet_bar_counts_done_failed_and_left() -> None:
    stream = io.StringIO()
    with fleet_bar(4, "cases", "case", stream=stream) as bar:
        bar.finished(True)
        bar.finished(False)
        bar.count(2, 1)
        assert (bar.done, bar.failed, bar.left) == (2, 1, 1)
    last = stream.getvalue().splitlines()[-1]
    assert last.startswith("cases:") and "3/4" in last
    assert "2 done, 1 failed, 1 left" in last and "cases/min" in last
