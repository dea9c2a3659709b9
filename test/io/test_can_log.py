"""A lab's CAN log as the pressure source: python-can's own writers make the logs.

Frames encoded with ``config/brake_rig.dbc`` (the live DAQ's codec) are written by
``can.BLFWriter``, ``can.ASCWriter``, ``can.TRCWriter`` and ``can.CanutilsLogWriter``, read back
by :class:`~brake_hil.io.can_log.CanLogReplay` and decoded to the pressures written, with the
acquisition stamps of the live DAQ (one sample period apart, the first "now" or the logged
time); dropouts and a frozen counter are counted as the live DAQ counts them. A damaged file
of each format is one line naming it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
import threading
import time

import can
import pytest

from brake_hil.errors import RecordingError
from brake_hil.io.can_codec import RigFrameCodec
from brake_hil.io.can_log import CanLogReplay, read_can_log
from brake_hil.runtime import StampMode

T0 = 1_700_000_000.0  # s, the log's first acquisition (epoch)
PERIOD_S = 0.001
COUNTER0 = 16_777_000  # wraps past 2**24 within the log
WRITERS: dict[str, Callable[[str], can.io.generic.MessageWriter]] = {
    "blf": can.BLFWriter,
    "asc": can.ASCWriter,
    "trc": can.TRCWriter,
    "log": can.CanutilsLogWriter,
}


def pressures(index: int) -> dict[str, float]:
    """The values of acquisition ``index`` (a ramp, distinct per sample)."""
    return {
        "p_i": 2.0e5 + 5.0e3 * index,
        "p_b": 1.5e5 + 4.0e3 * index,
        "F_k": 100.0 + index,
        "x_c": 2.0e-6 * (index % 50),
    }


def write_log(
    path: Path, indices: Sequence[int], extra: Sequence[tuple[int, float]] = ()
) -> RigFrameCodec:
    """Acquisitions ``indices`` (then ``extra``: (index, time) repeats) logged to ``path``."""
    codec = RigFrameCodec()
    frames = [
        frame
        for index in indices
        for frame in codec.encode(COUNTER0 + index, pressures(index), T0 + index * PERIOD_S)
    ]
    for index, at in extra:
        frames += codec.encode(COUNTER0 + index, pressures(index), at)
    frames.sort(key=lambda frame: frame.timestamp)
    writer = WRITERS[path.suffix[1:]](str(path))
    for frame in frames:
        writer.on_message_received(frame)
    writer.stop()
    return codec


def replay(
    path: Path, rate: float = 20.0, mode: StampMode = StampMode.SHIFT
) -> tuple[CanLogReplay, dict[str, list[tuple[int, float]]], float]:
    """Play ``path`` to its end; what each quantity received, and the wall time at the start."""
    log = CanLogReplay(path, rate=rate, stamp_mode=mode)
    got: dict[str, list[tuple[int, float]]] = {q: [] for q in log.quantities}
    outputs = {q: (got[q].append, lambda s, v: (s, v)) for q in log.quantities}
    started = time.time()
    assert log.run(outputs, threading.Event())
    return log, got, started


@pytest.mark.parametrize("kind", list(WRITERS))
def test_a_log_of_each_format_decodes_to_the_pressures_with_their_stamps(
    kind: str, tmp_path: Path
) -> None:
    path = tmp_path / f"rig.{kind}"
    codec = write_log(path, range(300))
    log, got, started = replay(path)
    assert len(log.frames) == 600 and log.replayed == 600
    assert log.published == 300
    scale = {q: 1.1 * s.scale for frame in codec._signals.values() for q, s in frame.items()}
    for quantity in ("p_i", "p_b", "F_k", "x_c"):
        values = [value for _, value in got[quantity]]
        expected = [pressures(i)[quantity] for i in range(300)]
        assert values == [pytest.approx(e, abs=scale[quantity]) for e in expected], quantity
    stamps = [stamp for stamp, _ in got["p_i"]]
    steps = [b - a for a, b in zip(stamps, stamps[1:])]  # from the counter: one period
    assert all(abs(step - 1_000_000) <= 2_000 for step in steps), steps  # float times: 2 us
    assert stamps == [stamp for stamp, _ in got["F_k"]]  # one acquisition, one stamp
    assert abs(stamps[0] / 1e9 - started) < 1.0  # shift: the first sample is "now"
    assert log.quantities == ["p_i", "p_b", "F_k", "x_c"]  # no BRAKE_AIR frame in the log
    summary = log.summary()
    assert summary["lost_samples"] == 0 and summary["stale_counters"] == 0
    assert summary["crc_errors"] == 0 and summary["frames_ok"] == 600


@pytest.mark.parametrize("kind", ["blf", "log"])  # their logged times are absolute
def test_keep_gives_the_logged_acquisition_times(kind: str, tmp_path: Path) -> None:
    path = tmp_path / f"rig.{kind}"
    write_log(path, range(100))
    _, got, _ = replay(path, mode=StampMode.KEEP)
    stamps = [stamp for stamp, _ in got["p_i"]]
    expected = [round((T0 + i * PERIOD_S) * 1e9) for i in range(100)]
    assert all(abs(a - b) <= 2_000 for a, b in zip(stamps, expected, strict=True)), stamps[:3]


def test_dropouts_and_a_frozen_counter_are_counted_as_the_live_daq_counts_them(
    tmp_path: Path,
) -> None:
    path = tmp_path / "rig.blf"
    kept = [i for i in range(200) if not 50 <= i < 60]  # 10 acquisitions lost by the DAQ
    frozen = [(120, T0 + 120.4 * PERIOD_S), (120, T0 + 120.7 * PERIOD_S)]  # repeated twice
    write_log(path, kept, frozen)
    log, got, _ = replay(path)
    summary = log.summary()
    assert summary["lost_samples"] == 2 * 10  # per frame (hydraulic, mechanical)
    assert summary["stale_counters"] == 2 * 2  # the repeats dropped, never published
    assert log.published == 190
    stamps = [stamp for stamp, _ in got["p_i"]]
    assert abs(stamps[50] - stamps[49] - 11_000_000) <= 2_000  # the gap kept, nothing invented
    assert len(set(stamps)) == 190


def test_the_rate_paces_the_replay(tmp_path: Path) -> None:
    path = tmp_path / "rig.log"
    write_log(path, range(400))  # 0.4 s logged
    started = time.monotonic()
    replay(path, rate=2.0)
    took = time.monotonic() - started
    assert took >= 0.19  # not faster than asked (0.2 s at rate 2); the upper bound is free


def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 2 // 3 - 5])  # inside a line, as a crash would cut it


def _garble(path: Path) -> None:
    data = path.read_bytes()
    middle = len(data) // 2
    path.write_bytes(data[:middle] + b"\x00\xffgarbage 12 zz ;;\n" * 3 + data[middle:])


@pytest.mark.parametrize("kind", list(WRITERS))
@pytest.mark.parametrize("damage", [_truncate, _garble], ids=["truncated", "garbled"])
def test_a_damaged_log_is_one_line_naming_it(
    kind: str, damage: Callable[[Path], None], tmp_path: Path
) -> None:
    path = tmp_path / f"rig.{kind}"
    write_log(path, range(300))
    damage(path)
    with pytest.raises(RecordingError) as raised:
        read_can_log(path)
    message = str(raised.value)
    assert message.startswith(f"{path}: ") and "\n" not in message, message


@pytest.mark.parametrize(
    "kind, line",
    [
        ("trc", b"    17)  12.0  DT  0100  Rx  8  ZZ ZZ\n"),  # python-can skips it with a warning
        ("log", b"(17x0.1) vcan0 100#ZZ\n"),
        ("asc", b"12.5 1 100 Rx d 8 zz 00 00 00 00 00 00 00\n"),
    ],
)
def test_a_garbled_line_of_a_text_log_is_one_line_naming_the_file(
    kind: str, line: bytes, tmp_path: Path
) -> None:
    path = tmp_path / f"rig.{kind}"
    write_log(path, range(30))
    lines = path.read_bytes().split(b"\n")
    half = len(lines) // 2
    path.write_bytes(b"\n".join(lines[:half]) + b"\n" + line + b"\n".join(lines[half:]))
    with pytest.raises(RecordingError) as raised:
        read_can_log(path)
    message = str(raised.value)
    assert message.startswith(f"{path}: ") and "\n" not in message, message


@pytest.mark.parametrize(
    "name, content, problem",
    [
        ("rig.blf", b"", "unreadable"),
        ("rig.log", b"", "no CAN frame"),
        ("rig.csv", b"x", "not a CAN log"),
        ("absent.asc", None, "no such CAN log"),
        ("other.log", b"(1700000000.000000) can0 7FF#0011223344556677\n", "no frame carrying p_i"),
    ],
)
def test_an_empty_unknown_or_missing_log_is_refused(
    name: str, content: bytes | None, problem: str, tmp_path: Path
) -> None:
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(RecordingError, match=problem):
        CanLogReplay(path)
