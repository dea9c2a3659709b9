"""The ROS-free CAN acquisition: each decoded sample sent once, STALE reported at its deadline."""

from __future__ import annotations

import threading
import time
import uuid

import can
import pytest

from brake_hil.io.can_acquisition import CanAcquisition
from brake_hil.io.can_daq import CanDaq, DaqStatus
from test.waiting import wait_until

INTERFACE = "virtual"
VALUES = {"p_i": 1.0e6, "p_b": 0.9e6, "F_k": 1000.0, "x_c": 1.0e-4, "p_a": 1.0e5}


def test_samples_are_sent_once_each_and_a_silent_bus_goes_stale() -> None:
    channel = f"brake_hil_acquisition_{uuid.uuid4().hex}"  # this test's own virtual bus
    changes: list[DaqStatus] = []
    daq = CanDaq(INTERFACE, channel, stale_after_s=0.010)
    acquisition = CanAcquisition(daq, False, lambda: changes.append(daq.health().status))
    assert acquisition.quantities == ["p_i"]  # the measured outputs not asked for
    sent: list[tuple[int, float]] = []
    stop = threading.Event()
    worker = threading.Thread(
        target=acquisition.run, args=({"p_i": (sent.append, lambda s, v: (s, v))}, stop)
    )
    sender = can.Bus(interface=INTERFACE, channel=channel)  # the rig's side
    worker.start()
    try:
        assert wait_until(lambda: daq.health().status is not DaqStatus.ADAPTER_LOST, 5.0)
        for counter in range(20):
            for frame in daq.codec.encode(counter, VALUES):
                sender.send(frame)
            time.sleep(0.001)
        assert wait_until(lambda: len(sent) == 20, 5.0)
        assert wait_until(lambda: DaqStatus.STALE in changes[1:], 5.0)  # silent after the frames
    finally:
        stop.set()
        worker.join(5.0)
        sender.shutdown()
    assert [value for _, value in sent] == [pytest.approx(VALUES["p_i"], rel=1e-4)] * 20
    assert acquisition.published == 20
    assert acquisition.stale_reports_ms  # the delay from the last frame to the report
    assert acquisition.summary()["status"] == "adapter_lost"  # closed at the end
    level, message, values = acquisition.status()
    assert message.startswith("DAQ") and values["published"] == 20
