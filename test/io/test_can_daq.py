"""CAN acquisition: the DBC codec, fault handling and health of CanDaq, on hardware-free buses.

Most tests use python-can's ``virtual`` interface inside this process (``INTERFACE`` is a
class-level constant, as in python-can's back2back tests, so they can be pointed at a real bus);
one runs slcan over a pseudo-terminal pair (:class:`SlcanPty`), which needs pyserial.
"""

from __future__ import annotations

from collections.abc import Iterator
import contextlib
from pathlib import Path
import threading
import time
import uuid

import can
import numpy as np
import pytest

from brake_hil.io.can_daq import (
    COUNTER_MODULUS,
    CanDaq,
    CanDaqError,
    DaqStatus,
    DbcError,
    RigFrameCodec,
    SlcanPty,
    crc8_sae_j1850,
    default_dbc_path,
)
from brake_hil.physics.measurement import SENSORS, measure
from test.waiting import wait_until

INTERFACE = "virtual"
QUANTITIES = ("p_i", "p_b", "F_k", "x_c", "p_a")


@pytest.fixture
def channel() -> str:
    """A virtual channel of this test alone."""
    return f"brake_hil_test_{uuid.uuid4().hex}"


@pytest.fixture
def sender(channel: str) -> Iterator[can.BusABC]:
    """The rig side of the bus."""
    bus = can.Bus(interface=INTERFACE, channel=channel)
    yield bus
    bus.shutdown()


@pytest.fixture
def daq(channel: str) -> Iterator[CanDaq]:
    """The acquisition side, open."""
    with CanDaq(INTERFACE, channel, stale_after_s=0.010) as acquisition:
        yield acquisition


def measured_samples(count: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Quantised sensor readings spread over each sensor's whole range."""
    rng = np.random.default_rng(seed)
    return {
        key: measure(rng.uniform(SENSORS[key].low, SENSORS[key].high, count), SENSORS[key], rng)
        for key in QUANTITIES
    }


def poll_until(daq: CanDaq, frames: int, timeout_s: float = 2.0) -> list:
    got: list = []
    deadline = time.monotonic() + timeout_s
    while len(got) < frames and time.monotonic() < deadline:
        got += daq.poll(timeout=0.01)
    return got


def test_crc8_matches_the_sae_j1850_check_value() -> None:
    assert crc8_sae_j1850(b"123456789") == 0x4B


def test_dbc_scaling_is_the_16_bit_sensor_ranges() -> None:
    codec = RigFrameCodec(default_dbc_path())
    assert codec.sample_period_ns == 1_000_000
    assert sorted(codec.quantities) == sorted(QUANTITIES)
    for key in QUANTITIES:
        sensor = SENSORS[key]
        lowest = codec.encode(0, {q: SENSORS[q].low for q in QUANTITIES})
        highest = codec.encode(0, {q: SENSORS[q].high for q in QUANTITIES})
        low = next(codec.decode(f).values[key] for f in lowest if key in codec.decode(f).values)
        high = next(codec.decode(f).values[key] for f in highest if key in codec.decode(f).values)
        assert low == sensor.low
        assert high == pytest.approx(sensor.high, rel=1e-12)


def test_frames_from_the_encoder_decode_to_the_values_sent(
    sender: can.BusABC, daq: CanDaq
) -> None:
    count = 300
    values = measured_samples(count)
    first_counter = COUNTER_MODULUS - 100  # the counter wraps half-way
    for k in range(count):
        frames = daq.codec.encode(first_counter + k, {q: values[q][k] for q in QUANTITIES})
        for frame in frames:
            sender.send(frame)
    got = poll_until(daq, 3 * count)
    assert len(got) == 3 * count
    for sample in got:
        k = sample.counter - first_counter
        for quantity, value in sample.values.items():
            assert value == values[quantity][k]  # bit-exact: same counts, same scaling
    counters = [s.counter for s in got if s.frame == "BRAKE_HYDRAULIC"]
    assert counters == list(range(first_counter, first_counter + count))  # unwrapped
    stamps = np.array([s.stamp_ns for s in got if s.frame == "BRAKE_HYDRAULIC"])
    assert np.all(np.diff(stamps) > 0)
    health = daq.health()
    assert health.frames_ok == 3 * count
    assert health.crc_errors == health.dlc_errors == health.unknown_ids == 0
    assert health.lost_samples == 0


def test_acquisition_stamps_follow_the_counter_not_the_arrival() -> None:
    codec = RigFrameCodec()
    daq = CanDaq(bus_factory=lambda: can.Bus(interface=INTERFACE, channel="unused"))
    t0 = 1_700_000_000_000_000_000
    jitter = [3, 0, 5, 1, 2, 0, 4]  # transport latency of each frame (ms)
    for k, late in enumerate(jitter):
        frame = codec.encode(k, {"p_i": 1e6, "p_b": 1e6})[0]
        frame.timestamp = (t0 + (k + late) * 1_000_000) / 1e9
        sample = daq._accept(frame)
        assert sample is not None
    # once the least-delayed frame (latency 0) has been seen, stamps sit on t0 + k ms
    last = daq._accept(codec.encode(7, {"p_i": 1e6, "p_b": 1e6}, (t0 + 9_000_000) / 1e9)[0])
    assert last is not None
    assert abs(last.stamp_ns - (t0 + 7_000_000)) < 1_000  # float seconds in python-can


def test_a_corrupted_frame_is_dropped_and_counted(sender: can.BusABC, daq: CanDaq) -> None:
    good = daq.codec.encode(1, {"p_i": 1e6, "p_b": 2e6})[0]
    flipped = bytearray(good.data)
    flipped[1] ^= 0x04  # one bit of p_i
    sender.send(
        can.Message(arbitration_id=good.arbitration_id, is_extended_id=False, data=flipped)
    )
    sender.send(
        can.Message(
            arbitration_id=good.arbitration_id, is_extended_id=False, data=bytes(good.data[:6])
        )
    )  # DLC 6
    sender.send(good)
    got = poll_until(daq, 1)
    time.sleep(0.02)
    got += daq.poll(timeout=0.01)
    assert [s.values for s in got] == [daq.codec.decode(good).values]
    health = daq.health()
    assert (health.crc_errors, health.dlc_errors, health.frames_ok) == (1, 1, 1)
    assert "crc8" in health.last_error or "DLC" in health.last_error


def test_an_unknown_id_is_dropped_and_counted(sender: can.BusABC, daq: CanDaq) -> None:
    sender.send(can.Message(arbitration_id=0x7FF, is_extended_id=False, data=bytes(8)))
    sender.send(can.Message(arbitration_id=0x120, is_extended_id=True, data=bytes(8)))
    sender.send(can.Message(arbitration_id=0x120, is_extended_id=False, is_remote_frame=True))
    assert poll_until(daq, 1, timeout_s=0.2) == []
    health = daq.health()
    assert health.unknown_ids == 3
    assert health.frames_ok == 0


def test_a_silent_bus_is_stale_within_10_ms(sender: can.BusABC, daq: CanDaq) -> None:
    assert daq.health().status is DaqStatus.STALE  # nothing received yet
    silent_since = time.monotonic()  # the frame's deadline is armed when it is read, later
    sender.send(daq.codec.encode(1, {"p_i": 1e6, "p_b": 2e6})[0])
    assert len(poll_until(daq, 1)) == 1
    assert daq.health().status is DaqStatus.OK
    while daq.health().status is DaqStatus.OK:
        daq.poll(timeout=0.001)
    # STALE at the deadline the frame armed (never before it; the latency itself is measured
    # by benchmarks/bench_stale.py: a test's bound must hold on a busy 2-core runner)
    assert 0.010 <= time.monotonic() - silent_since < 1.0
    health = daq.health()
    assert health.status is DaqStatus.STALE
    assert health.age_s >= 0.010
    assert health.status.diagnostic_level == 3  # diagnostic_msgs STALE


def test_a_counter_gap_is_reported_as_lost_samples(sender: can.BusABC, daq: CanDaq) -> None:
    for counter in (10, 11, 15, 16):
        sender.send(daq.codec.encode(counter, {"p_i": 1e6, "p_b": 2e6})[0])
    assert len(poll_until(daq, 4)) == 4
    assert daq.health().lost_samples == 3


def test_an_error_frame_is_a_bus_error(sender: can.BusABC, daq: CanDaq) -> None:
    sender.send(can.Message(is_error_frame=True, arbitration_id=0x20000004))
    sender.send(daq.codec.encode(1, {"p_i": 1e6, "p_b": 2e6})[0])
    assert len(poll_until(daq, 1)) == 1
    health = daq.health()
    assert health.bus_errors == 1
    assert health.status is DaqStatus.BUS_ERROR  # fresh frames, but a recent bus error
    assert health.status.diagnostic_level == 1


class FlakyBus(can.BusABC):
    """A bus whose adapter fails: ``recv`` raises OSError, as a pulled USB adapter does."""

    def __init__(self, channel: str, failures: list[str]) -> None:
        self.inner = can.Bus(interface=INTERFACE, channel=channel)
        self.failures = failures
        super().__init__(channel=channel)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        if self.failures and self.failures[0] == "unplug":
            self.failures.pop(0)
            raise OSError(19, "No such device")
        return self.inner.recv(timeout), False

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self.inner.send(msg, timeout)

    def shutdown(self) -> None:
        self.inner.shutdown()
        super().shutdown()


def test_a_lost_adapter_is_reopened_with_backoff(channel: str, sender: can.BusABC) -> None:
    failures = ["unplug"]
    opened: list[float] = []
    unavailable = {"left": 2}  # the adapter stays away for two attempts

    def factory() -> can.BusABC:
        opened.append(time.monotonic())
        if len(opened) > 1 and unavailable["left"]:
            unavailable["left"] -= 1
            raise can.CanInitializationError("adapter not found")
        return FlakyBus(channel, failures)

    with CanDaq(INTERFACE, channel, bus_factory=factory, reconnect_min_s=0.02) as daq:
        assert daq.poll(timeout=0.01) == []  # recv raises: adapter lost, not an exception
        assert daq.health().status is DaqStatus.ADAPTER_LOST
        deadline = time.monotonic() + 2.0
        while daq.health().status is DaqStatus.ADAPTER_LOST and time.monotonic() < deadline:
            daq.poll(timeout=0.01)
        sender.send(daq.codec.encode(5, {"p_i": 1e6, "p_b": 2e6})[0])
        assert len(poll_until(daq, 1)) == 1
        health = daq.health()
    assert health.reconnects == 1
    assert len(opened) == 4  # first open, two refused attempts, the successful one
    waits = np.diff(opened[1:])
    assert waits[1] >= 1.9 * 0.02  # the wait doubled after a failed attempt
    assert "adapter not found" in health.last_error or "No such device" in health.last_error


def test_an_unknown_interface_is_refused() -> None:
    with pytest.raises(CanDaqError, match="no_such_interface"):
        CanDaq("no_such_interface", "x").open()


def test_a_dbc_without_counter_or_checksum_is_refused(tmp_path: Path) -> None:
    dbc = tmp_path / "bad.dbc"
    dbc.write_text(
        'VERSION ""\n\nBS_:\n\nBU_: A\n\nBO_ 256 RAW: 8 A\n'
        ' SG_ p_i : 0|16@1+ (1,0) [0|65535] "Pa" A\n'
    )
    with pytest.raises(DbcError, match="RAW lacks sample_counter or crc8"):
        RigFrameCodec(dbc)
    with pytest.raises(DbcError, match="cannot load"):
        RigFrameCodec(tmp_path / "missing.dbc")


def test_frames_over_slcan_on_a_pty_decode_to_the_values_sent(tmp_path: Path) -> None:
    pytest.importorskip("serial", reason="python-can's slcan interface needs pyserial")
    count = 200
    values = measured_samples(count, seed=1)
    link = tmp_path / "rig_can"
    with SlcanPty(link) as device:
        codec = RigFrameCodec()
        with CanDaq("slcan", str(link), 1_000_000, bus_kwargs={"sleep_after_open": 0}) as daq:

            def play() -> None:
                for k in range(count):
                    device.send(codec.encode(k, {q: values[q][k] for q in QUANTITIES}))
                    time.sleep(0.0005)

            thread = threading.Thread(target=play)
            thread.start()
            got = poll_until(daq, 3 * count, timeout_s=5.0)
            thread.join()
            health = daq.health()
    assert len(got) == 3 * count
    for sample in got:
        for quantity, value in sample.values.items():
            assert value == values[quantity][sample.counter]
    assert health.crc_errors == health.bus_errors == health.lost_samples == 0


def test_an_emulated_adapter_that_closes_lets_its_reader_read_what_it_sent(
    tmp_path: Path,
) -> None:
    """Closing a pseudo-terminal discards what its reader has not read: a busy reader lost
    a run's last 18 samples so. The adapter waits (``drain_s``) until the reader has read
    them; without the wait the same reader gets none."""
    pytest.importorskip("serial", reason="python-can's slcan interface needs pyserial")
    count = 40  # 120 frames, under a pseudo-terminal's 4 KiB buffer
    values = measured_samples(count, seed=2)
    codec = RigFrameCodec()
    received = []
    for drain_s in (5.0, 0.0):
        link = tmp_path / f"rig_can_{drain_s:g}"
        device = SlcanPty(link)
        daq = CanDaq("slcan", str(link), 1_000_000, bus_kwargs={"sleep_after_open": 0})
        assert poll_until_open(device, daq)
        for k in range(count):
            assert device.send(codec.encode(k, {q: values[q][k] for q in QUANTITIES}))
        # nothing read yet: the reader is busy elsewhere (the kernel queues the bytes for the
        # reader on a worker thread, so on a busy machine they show after a moment)
        assert wait_until(device.unread, timeout_s=5.0)
        closing = threading.Thread(target=device.close, args=(drain_s,))
        closing.start()
        time.sleep(0.3)  # the reader comes back late
        received.append(len(poll_until(daq, 3 * count, timeout_s=5.0)))
        closing.join()
        with contextlib.suppress(can.CanError):  # its adapter is gone: "C" cannot be sent
            daq.close()
    assert received == [3 * count, 0]


def poll_until_open(device: SlcanPty, daq: CanDaq, timeout_s: float = 5.0) -> bool:
    """Answer the reader's commands until it has opened the channel (the DAQ opens its
    adapter when polled)."""
    deadline = time.monotonic() + timeout_s
    while not device.poll_reader() and time.monotonic() < deadline:
        assert daq.poll(timeout=0.01) == []
    return device.reader_open


def test_a_frozen_sample_counter_is_never_fresh() -> None:
    codec = RigFrameCodec()
    daq = CanDaq(
        bus_factory=lambda: can.Bus(interface=INTERFACE, channel="unused"), stale_after_s=0.05
    )
    daq.open()
    try:
        frame = codec.encode(5000, {"p_i": 1e6, "p_b": 1e6})[0]
        assert daq._accept(frame) is not None
        deadline = daq.stale_deadline_ns
        assert deadline is not None
        assert [daq._accept(frame) for _ in range(200)] == [None] * 200  # the DAQ repeats it
        assert daq.stale_deadline_ns == deadline  # repeats do not re-arm the deadline
        time.sleep(0.06)
        health = daq.health()
        assert health.status is DaqStatus.STALE and health.stale_counters == 200
        assert health.frames_ok == 1 and "did not advance" in health.last_error
        # a restarted DAQ (counter far behind) is fresh again
        restarted = codec.encode(3, {"p_i": 1e6, "p_b": 1e6})[0]
        assert daq._accept(restarted) is not None
        assert daq.health().status is DaqStatus.OK
    finally:
        daq.close()
