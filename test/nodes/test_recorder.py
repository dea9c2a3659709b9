"""The recorder node as its own process, fed at 1 kHz by a real rclpy node in this process.

Each test runs on its own ROS domain (101-200, apart from the other node tests' 1-100) with
loopback discovery. Recordings are read back with the independent ``mcap`` reader and the ROS 2
decoder of ``mcap_ros2``, and with :func:`brake_hil.io.recording_reader.read_recording`.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
import os
from pathlib import Path
import signal
import struct
import subprocess
import sys
import threading
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from mcap.exceptions import McapError
from mcap.reader import NonSeekingReader, make_reader
from mcap_ros2.decoder import DecoderFactory
import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.node import Node
import yaml

from brake_hil.app.chain import ros_environment, wait_until_quiet
from brake_hil.io.recording_reader import read_recording
from brake_hil.nodes import common
from brake_hil.topics import AIR_PRESSURE, MASTER_CYLINDER_PRESSURE, MEASURED_OUTPUTS

SAMPLE_TOPICS = (MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS, AIR_PRESSURE)
T0 = 1_700_000_000_000_000_000
PERIOD_NS = 1_000_000
STEP = {"x_c": 1e-9}
"""Sample k carries the value k * STEP (default 1): 1 nm a sample keeps x_c physical."""


def domain_id() -> int:
    """A ROS domain for one test (101-200)."""
    return 101 + (os.getpid() * 7919 + time.time_ns() // 1_000_000) % 100


@contextmanager
def recorder_process(
    tmp_path: Path, domain: int, **parameters: object
) -> Iterator[subprocess.Popen[bytes]]:
    """``python -m brake_hil.nodes.recorder`` recording into ``tmp_path/bag``."""
    arguments = {"output_dir": str(tmp_path), "bag_name": "bag", **parameters}
    command = [sys.executable, "-m", "brake_hil.nodes.recorder", "--ros-args"]
    for name, value in arguments.items():
        command += ["-p", f"{name}:={value}"]
    log = (tmp_path / "recorder.log").open("wb")
    process = subprocess.Popen(command, env=ros_environment(domain), stdout=log, stderr=log)
    try:
        yield process
    finally:
        if process.poll() is None:
            process.kill()
        process.wait(10)
        log.close()


class Publisher:
    """A real rclpy node publishing samples ``k`` (value k, stamp T0 + k ms) at 1 kHz on the
    contract's sample topics and ``/diagnostics``, paced by absolute deadlines."""

    def __init__(self, domain: int) -> None:
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = Node("test_publisher", context=self.context)
        self.outputs: list[tuple[Any, Any]] = [
            (
                self.node.create_publisher(
                    common.message_class(spec), spec.name, common.SAMPLE_QOS
                ),
                common.MessageBuilder(spec, "rig"),
            )
            for spec in SAMPLE_TOPICS
        ]
        self.diagnostics = self.node.create_publisher(
            DiagnosticArray, "/diagnostics", common.SAMPLE_QOS
        )
        self.unrelated = self.node.create_publisher(
            common.message_class(AIR_PRESSURE), "/not_brake/pressure", common.SAMPLE_QOS
        )
        self.steps = [STEP.get(spec.quantity, 1.0) for spec in SAMPLE_TOPICS]
        self.published = 0
        self.stop = threading.Event()
        self._thread: threading.Thread | None = None

    def wait_for_recorder(self, timeout_s: float = 30.0) -> None:
        publishers = [p for p, _ in self.outputs] + [self.diagnostics]
        deadline = time.monotonic() + timeout_s
        while not all(p.get_subscription_count() for p in publishers):
            assert time.monotonic() < deadline, "the recorder did not subscribe in time"
            time.sleep(0.05)

    def _publish(self, count: int) -> None:
        array = DiagnosticArray()
        array.status = [DiagnosticStatus(name="test", message="")]
        start = time.monotonic_ns() + PERIOD_NS
        for k in range(count):
            if self.stop.is_set():
                return
            delay = start + k * PERIOD_NS - time.monotonic_ns()
            if delay > 0:
                time.sleep(delay / 1e9)
            stamp = T0 + k * PERIOD_NS
            for (publisher, build), step in zip(self.outputs, self.steps):
                publisher.publish(build(stamp, float(k) * step))
            array.header.stamp.sec, array.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
            array.status[0].message = str(k)
            self.diagnostics.publish(array)
            self.unrelated.publish(self.outputs[0][1](stamp, float(k)))
            self.published = k + 1

    def start(self, count: int) -> None:
        self._thread = threading.Thread(target=self._publish, args=(count,), daemon=True)
        self._thread.start()

    def join(self) -> None:
        assert self._thread is not None
        self._thread.join(30)

    def close(self) -> None:
        self.stop.set()
        if self._thread is not None:
            self._thread.join(5)
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


@pytest.fixture
def publisher_and_domain() -> Iterator[tuple[Publisher, int]]:
    domain = domain_id()
    publisher = Publisher(domain)
    yield publisher, domain
    publisher.close()


def listed_files(bag: Path) -> list[str]:
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    return list(info["relative_file_paths"])


def decoded_messages(stream: Any) -> Iterator[tuple[Any, Any, Any, Any]]:
    """Every message of one MCAP file, decoded; a file cut mid-record read up to the cut.

    The indexed reader needs the footer; a recorder killed while writing a chunk leaves
    partial bytes where its last footer was, so such a file is read from its start, record
    by record, up to the first record the kill cut short.
    """
    try:
        make_reader(stream).get_summary()
    except McapError:
        stream.seek(0)
        reader = NonSeekingReader(stream, decoder_factories=[DecoderFactory()])
        try:  # in file order: the recorder writes each topic's messages in time order
            yield from reader.iter_decoded_messages(log_time_order=False)
        except (McapError, struct.error):  # the record the kill cut short
            return
        return
    stream.seek(0)
    yield from make_reader(stream, decoder_factories=[DecoderFactory()]).iter_decoded_messages()


def values_by_topic(bag: Path) -> dict[str, list[float]]:
    """Each topic's values in log-time order, decoded by mcap_ros2 from every listed file."""
    found: dict[str, list[float]] = {}
    for name in listed_files(bag):
        with (bag / name).open("rb") as stream:
            for _schema, channel, message, decoded in decoded_messages(stream):
                if channel.topic == "/diagnostics":
                    value = float(decoded.status[0].message)
                else:
                    spec = next(s for s in SAMPLE_TOPICS if s.name == channel.topic)
                    step = STEP.get(spec.quantity, 1.0)
                    value = common.value_reader(spec)(decoded)
                    value = value if step == 1.0 else float(round(value / step))
                    stamp = common.stamp_ns(decoded)
                    assert stamp == T0 + round(value) * PERIOD_NS  # header.stamp kept as sent
                    # the log time is the receive time (wall clock of the test), not the stamp
                    assert abs(message.log_time - time.time_ns()) < 600 * 1_000_000_000
                found.setdefault(channel.topic, []).append(value)
    return found


def log_times_in_file_order(bag: Path) -> list[int]:
    """The log time of every message as the files hold them (not sorted by the reader)."""
    times: list[int] = []
    for name in listed_files(bag):
        with (bag / name).open("rb") as stream:
            reader = make_reader(stream)
            times += [m.log_time for _, _, m in reader.iter_messages(log_time_order=False)]
    return times


def check_recording(bag: Path, topics: Sequence[str], count: int) -> None:
    """Every topic holds samples 0..count-1 in order, and read_recording agrees.

    The recorder writes in receive-time order across topics: log times never go back.
    """
    times = log_times_in_file_order(bag)
    assert len(times) >= count * len(topics)
    assert all(b >= a for a, b in zip(times, times[1:])), "log times go backwards"
    found = values_by_topic(bag)
    assert sorted(found) == sorted(topics)
    for topic in topics:
        assert found[topic] == list(range(count)), topic
    recording = read_recording(bag, required=SAMPLE_TOPICS)
    assert recording.start_stamp_ns == T0
    np.testing.assert_array_equal(recording.block_force, np.arange(count, dtype=float))


def test_recorder_keeps_every_message_at_1khz_and_finishes_on_sigterm(
    tmp_path: Path, publisher_and_domain: tuple[Publisher, int]
) -> None:
    publisher, domain = publisher_and_domain
    count = 3000
    with recorder_process(tmp_path, domain, max_file_duration_s=1.0) as recorder:
        publisher.wait_for_recorder()
        began = time.monotonic()
        publisher.start(count)
        publisher.join()
        elapsed = time.monotonic() - began
        time.sleep(0.2)
        recorder.send_signal(signal.SIGTERM)  # while the recorder runs, its files open
        assert recorder.wait(20) == 0, (tmp_path / "recorder.log").read_text()
    assert publisher.published == count
    # the pace is the publisher's, not the recorder's: printed, not asserted (a busy 2-core
    # host can take 6.9 s for these 3 s)
    print(f"published {count} per topic in {elapsed:.2f} s")
    bag = tmp_path / "bag"
    topics = [s.name for s in SAMPLE_TOPICS] + ["/diagnostics"]
    assert len(listed_files(bag)) >= 3  # split every second of log time
    assert sorted(listed_files(bag)) == sorted(p.name for p in bag.glob("*.mcap"))
    check_recording(bag, topics, count)  # no message lost: 6 topics x 1 kHz


def test_a_recorder_killed_mid_run_leaves_a_readable_recording(
    tmp_path: Path, publisher_and_domain: tuple[Publisher, int]
) -> None:
    publisher, domain = publisher_and_domain
    flush_interval = 0.25
    with recorder_process(
        tmp_path, domain, max_file_duration_s=1.0, flush_interval_s=flush_interval
    ) as recorder:
        publisher.wait_for_recorder()
        publisher.start(10_000)
        while publisher.published < 2500:
            time.sleep(0.01)
        recorder.send_signal(signal.SIGKILL)
        killed_at = publisher.published
        recorder.wait(10)
    publisher.stop.set()
    bag = tmp_path / "bag"
    assert len(listed_files(bag)) >= 2  # the closed files and the open one
    found = values_by_topic(bag)
    lengths = {topic: len(values) for topic, values in found.items()}
    for topic, values in found.items():
        assert values == list(range(len(values))), topic  # a gap-free prefix of each topic
    # all but the last chunk: what arrived up to the last commit (flush_interval_s)
    assert min(lengths.values()) >= killed_at - 1000 * (2 * flush_interval + 0.25)
    recording = read_recording(bag, required=SAMPLE_TOPICS)
    assert recording.time.size >= min(lengths.values()) - 1


def test_a_recorder_starved_for_8_s_catches_up_and_loses_nothing(
    tmp_path: Path, publisher_and_domain: tuple[Publisher, int]
) -> None:
    # A busy runner can starve the recorder for seconds: the recorder is stopped (SIGSTOP)
    # for 8 s while 1 kHz samples keep coming, longer than the 5 s history the sample topics
    # had (Fast DDS's default limit), which lost what came in between. The 30 s history of
    # SAMPLE_QOS and the loopback profile's resource limits hold it until the recorder runs.
    publisher, domain = publisher_and_domain
    count, paused_s = 10_000, 8.0
    with recorder_process(tmp_path, domain) as recorder:
        publisher.wait_for_recorder()
        publisher.start(count)
        while publisher.published < 1000:
            time.sleep(0.01)
        recorder.send_signal(signal.SIGSTOP)
        paused_at = publisher.published
        time.sleep(paused_s)
        samples_while_paused = publisher.published - paused_at
        recorder.send_signal(signal.SIGCONT)
        publisher.join()
        outputs = [p for p, _ in publisher.outputs] + [publisher.diagnostics]
        assert common.wait_for_acks(outputs, 60.0), "the recorder did not acknowledge all"
        assert wait_until_quiet(tmp_path / "bag", timeout_s=60.0), "the recorder never caught up"
        recorder.send_signal(signal.SIGINT)
        assert recorder.wait(20) == 0, (tmp_path / "recorder.log").read_text()
    assert publisher.published == count
    assert samples_while_paused > 5000  # more than the old history held
    topics = [s.name for s in SAMPLE_TOPICS] + ["/diagnostics"]
    check_recording(tmp_path / "bag", topics, count)
