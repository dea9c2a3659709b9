"""The ROS-free replay: every sample sent once, at its pace, stamps that always increase."""

from __future__ import annotations

from pathlib import Path
import threading
import time

import pytest

from brake_hil.errors import BrakeHilError
from brake_hil.io.replay import Replay
from brake_hil.topics import MASTER_CYLINDER_PRESSURE

BAG = Path(__file__).resolve().parents[2] / "bags" / "one_washer_lti"


def _sinks(replay: Replay) -> tuple[list, dict]:
    sent: dict = {spec: [] for spec in replay.specs}
    outputs = [(sent[spec].append, lambda stamp, value: (stamp, value)) for spec in replay.specs]
    return outputs, sent


def test_a_short_replay_sends_each_sample_once_with_increasing_stamps() -> None:
    replay = Replay(str(BAG), "shift", True, start_offset=1.0, duration=0.05)
    assert replay.specs[0] is MASTER_CYLINDER_PRESSURE
    assert len(replay.specs) > 1  # the measured outputs too
    outputs, sent = _sinks(replay)
    began = time.time_ns()
    replay.play(outputs, threading.Event(), rate=1.0)
    pressures = sent[MASTER_CYLINDER_PRESSURE]
    assert len(pressures) == replay.samples == replay.published
    assert replay.passes == 1
    stamps = [stamp for stamp, _ in pressures]
    assert stamps == sorted(set(stamps))
    assert abs(stamps[0] - began) < 1e9  # shifted to the time of sending
    assert [v for _, v in pressures] == replay.values[MASTER_CYLINDER_PRESSURE]
    assert all(len(column) == replay.samples for column in sent.values())


def test_a_looped_replay_keeps_its_stamps_increasing_until_stopped() -> None:
    replay = Replay(str(BAG), "keep", False, duration=0.02)
    stop = threading.Event()
    outputs, sent = _sinks(replay)

    def follow(deadline_ns: int, wake_ns: int) -> None:
        if replay.published >= 3 * replay.samples:
            stop.set()

    replay.play(outputs, stop, rate=4.0, loop=True, followers=[follow])
    stamps = [stamp for stamp, _ in sent[MASTER_CYLINDER_PRESSURE]]
    assert len(stamps) == 3 * replay.samples
    assert replay.passes >= 2
    assert all(later > earlier for earlier, later in zip(stamps, stamps[1:]))
    assert stamps[0] == int(replay.stamps[0])  # kept as recorded


@pytest.mark.parametrize(
    ("path", "mode", "duration", "says"),
    [
        ("", "shift", 0.0, "recording"),
        (str(BAG), "sideways", 0.0, "stamp_mode"),
        (str(BAG), "shift", 0.0005, "fewer than 2"),
    ],
)
def test_a_replay_that_cannot_play_says_why(
    path: str, mode: str, duration: float, says: str
) -> None:
    with pytest.raises(BrakeHilError, match=says):
        Replay(path, mode, True, duration=duration)
