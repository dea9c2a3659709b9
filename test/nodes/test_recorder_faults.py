"""The recorder process under faults: a disk that fills, a ``kill -9``; and what is recovered.

The recorder runs as its own process, fed at 1 kHz by a real rclpy node in this process (the
publisher of ``test_recorder``). A full disk is a per-process file size limit
(``RLIMIT_FSIZE``, with ``SIGXFSZ`` ignored so the write fails with ``EFBIG``) or, as root, a
small tmpfs (``ENOSPC``). What the recorder leaves is read back with the project's reader
(whole chunks of unfinished files), with python ``mcap``'s streaming reader, and after
``brake-hil recover`` with ``mcap``'s seeking reader and ``rosbags``.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
import os
from pathlib import Path
import resource
import shutil
import signal
import subprocess
import sys
import time

from mcap.reader import make_reader
import pytest
from rosbags.rosbag2 import Reader

from brake_hil.app.chain import ros_environment
from brake_hil.app.recover import run_recover
from brake_hil.io.mcap_salvage import salvage_file
from brake_hil.io.recording_reader import read_recording
from brake_hil.io.unfinished import open_unfinished
from brake_hil.nodes import common
from test.nodes.harness import Collector, ros_domain
from test.nodes.test_recorder import SAMPLE_TOPICS, Publisher, domain_id
from test.waiting import wait_until

RECORDED = [s.name for s in SAMPLE_TOPICS] + ["/diagnostics"]


@contextmanager
def recorder(
    tmp_path: Path,
    output_dir: Path,
    domain: int,
    preexec: Callable[[], None] | None = None,
    **parameters: object,
) -> Iterator[subprocess.Popen[bytes]]:
    """``python -m brake_hil.nodes.recorder`` writing ``output_dir/bag``; log in tmp_path."""
    arguments = {"output_dir": str(output_dir), "bag_name": "bag", **parameters}
    command = [sys.executable, "-m", "brake_hil.nodes.recorder", "--ros-args"]
    for name, value in arguments.items():
        command += ["-p", f"{name}:={value}"]
    with (tmp_path / "recorder.log").open("wb") as log:
        process = subprocess.Popen(
            command, env=ros_environment(domain), stdout=log, stderr=log, preexec_fn=preexec
        )
        try:
            yield process
        finally:
            if process.poll() is None:
                process.kill()
            process.wait(10)


def file_size_limit(limit_bytes: int) -> Callable[[], None]:
    """A ``preexec_fn``: files of the child may not grow past ``limit_bytes``."""

    def apply() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # write() fails with EFBIG instead
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    return apply


def prefix_lengths(bag: Path) -> dict[str, int]:
    """Messages per topic read by python mcap's streaming reader from every file's whole
    chunks; each topic must be a gap-free prefix 0, 1, 2, ... of what was published."""
    found: dict[str, list[int]] = {}
    for file in sorted(bag.glob("*.mcap")):
        salvaged = salvage_file(file)
        for message in salvaged.messages:
            topic = salvaged.channels[message.channel_id].topic
            found.setdefault(topic, []).append(message.log_time_ns)
    for topic, times in found.items():
        assert times == sorted(times), topic
    return {topic: len(times) for topic, times in found.items()}


def run_until_the_disk_fills(
    tmp_path: Path, output_dir: Path, preexec: Callable[[], None] | None
) -> tuple[int, str, list[object]]:
    """Record until the recorder gives up; returns its exit status, log and its statuses."""
    domain = domain_id()
    publisher = Publisher(domain)
    with ros_domain(domain):
        collector = Collector([], arrays=["/diagnostics"])
    try:
        with recorder(tmp_path, output_dir, domain, preexec) as process:
            publisher.wait_for_recorder()
            # the collector must have found the recorder's /diagnostics publisher (beside the
            # test publisher's) before the disk fills: the recorder waits for the acks of the
            # subscribers it has matched, and on a busy runner discovery can come later
            wait_until(lambda: collector.publishers("/diagnostics") >= 2, 30.0)
            publisher.start(60_000)
            status = process.wait(90)  # it must stop on its own
            publisher.stop.set()
            # its status was acknowledged before it exited; the collector's thread may take
            # it later on a busy host (a quiet one can read none after 0.5 s)
            wait_until(lambda: recorder_statuses(collector), 10.0)
            time.sleep(0.5)  # and nothing more comes
    finally:
        publisher.close()
        statuses = recorder_statuses(collector)
        collector.close()
    return status, (tmp_path / "recorder.log").read_text(errors="replace"), statuses


def recorder_statuses(collector: Collector) -> list[object]:
    """The ``recorder`` statuses the collector has received on ``/diagnostics``."""
    return [
        s
        for _, array in collector.arrays["/diagnostics"]
        for s in array.status
        if s.name == "recorder"
    ]


def check_stopped_cleanly(
    bag: Path, status: int, log: str, statuses: list[object], errno_text: str
) -> None:
    """Exit 1, one error line, one ERROR status; every message it counted reads back."""
    assert status == 1, log
    assert "Traceback" not in log, log
    errors = [line for line in log.splitlines() if line.startswith("recorder: error:")]
    assert len(errors) == 1, log
    assert errno_text in errors[0] and str(bag) in errors[0], errors[0]
    assert len(statuses) == 1, statuses
    (report,) = statuses
    assert report.level == bytes([common.ERROR])  # type: ignore[attr-defined]
    on_disk = int(common.status_values(report)["messages_on_disk"])  # type: ignore[arg-type]
    assert on_disk > 1000  # it recorded for a while before the disk filled
    recovered = open_unfinished(bag)  # the files stop after their last whole chunk
    assert recovered is not None
    assert recovered.message_count == on_disk  # nothing it had written is lost
    lengths = prefix_lengths(bag)
    assert sum(lengths.values()) == on_disk
    assert set(lengths) == set(RECORDED)
    recording = read_recording(bag, required=SAMPLE_TOPICS)
    assert recording.time.size >= min(lengths.values()) - 1


def test_a_file_size_limit_stops_the_recorder_with_one_line_and_an_error_status(
    tmp_path: Path,
) -> None:
    status, log, statuses = run_until_the_disk_fills(tmp_path, tmp_path, file_size_limit(200_000))
    check_stopped_cleanly(tmp_path / "bag", status, log, statuses, "File too large")


@pytest.fixture
def small_tmpfs(tmp_path: Path) -> Iterator[Path]:
    """A 512 KiB tmpfs (root only; skipped where mounting is not allowed)."""
    mount = tmp_path / "small_disk"
    mount.mkdir()
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("mounting a tmpfs needs root")
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", str(mount)],
        capture_output=True,
        check=False,
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs: {done.stderr.decode().strip()}")
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], check=False)


def test_a_full_tmpfs_stops_the_recorder_with_one_line_and_an_error_status(
    tmp_path: Path, small_tmpfs: Path
) -> None:
    status, log, statuses = run_until_the_disk_fills(tmp_path, small_tmpfs, None)
    check_stopped_cleanly(small_tmpfs / "bag", status, log, statuses, "No space left")
    # the finished copy goes to another disk
    result = run_recover(small_tmpfs / "bag", tmp_path / "copy")
    with Reader(tmp_path / "copy") as reader:
        assert (
            reader.message_count
            == result.message_count
            == sum(prefix_lengths(small_tmpfs / "bag").values())
        )


def test_a_killed_split_recording_is_read_and_recovered(tmp_path: Path) -> None:
    domain = domain_id()
    publisher = Publisher(domain)
    try:
        with recorder(
            tmp_path, tmp_path, domain, None, max_file_duration_s=1.0, flush_interval_s=0.1
        ) as process:
            publisher.wait_for_recorder()
            publisher.start(10_000)
            while publisher.published < 3500:
                time.sleep(0.01)
            process.send_signal(signal.SIGKILL)
            killed_at = publisher.published
            process.wait(10)
    finally:
        publisher.close()
    bag = tmp_path / "bag"
    files = sorted(bag.glob("*.mcap"))
    assert len(files) >= 3  # split every second; the last one unfinished
    lengths = prefix_lengths(bag)
    # lost: the open chunk (0.1 s) and what DDS had not delivered; generous on a busy runner
    assert min(lengths[t] for t in RECORDED) >= killed_at - 1500
    recording = read_recording(bag, required=SAMPLE_TOPICS)
    assert recording.time.size >= min(lengths.values()) - 1

    result = run_recover(bag)
    assert result.reason is not None
    assert result.message_count == sum(lengths.values())
    copy = result.output
    assert len(list(copy.glob("*.mcap"))) == len(files)
    total = 0
    for file in sorted(copy.glob("*.mcap")):
        with file.open("rb") as stream:
            reader = make_reader(stream)
            summary = reader.get_summary()
            assert summary is not None and summary.statistics is not None
            count = sum(1 for _ in reader.iter_messages())
            assert count == summary.statistics.message_count
            total += count
    assert total == result.message_count
    with Reader(copy) as bag_reader:
        assert {t: i.msgcount for t, i in bag_reader.topics.items()} == lengths
        assert sum(1 for _ in bag_reader.messages()) == bag_reader.message_count == total
