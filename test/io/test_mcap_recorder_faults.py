"""The streaming MCAP writer when writing fails (disk full) and its chunk age bound.

A full disk is a file size limit (``RLIMIT_FSIZE``, ``SIGXFSZ`` ignored so that writes fail
with ``EFBIG``) set inside a child process, which writes with the real recorder and reports
what it was told; this process then reads the files with independent readers.
"""

from __future__ import annotations

import json
from pathlib import Path
import subprocess
import sys
import textwrap
import time

from rosbags.rosbag2 import Reader
import yaml

from brake_hil.io.mcap_salvage import is_finished, salvage_file
from brake_hil.io.recording_reader import read_recording
from test.io.test_mcap_recorder import TOPICS, new_recorder, record

CHILD = textwrap.dedent(
    """
    import json, resource, signal, sys
    from pathlib import Path
    from brake_hil.errors import RecordingWriteError
    from test.io.test_mcap_recorder import new_recorder, record

    path, mode, limit = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3])
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    recorder = new_recorder(path, chunk_bytes=8_000)
    report = {}
    if mode == "during":
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
        try:
            record(recorder, 20_000)
        except RecordingWriteError as err:
            report["error"] = str(err)
        try:
            recorder.write(0, 1, b"x")
        except RecordingWriteError:
            report["refused_after"] = True
    else:  # the data fits, the summary does not
        record(recorder, 2_000)
        recorder.flush()
        size = (path / f"{path.name}_0.mcap").stat().st_size
        resource.setrlimit(resource.RLIMIT_FSIZE, (size + 40, size + 40))
    report["on_disk"] = sum(f.message_count for f in recorder.files())
    try:
        recorder.close()
        report["closed"] = True
    except RecordingWriteError as err:
        report["close_error"] = str(err)
        report["on_disk"] = sum(f.message_count for f in recorder.files())
    print(json.dumps(report))
    """
)


def run_child(path: Path, mode: str, limit: int = 0) -> dict[str, object]:
    done = subprocess.run(
        [sys.executable, "-c", CHILD, str(path), mode, str(limit)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    report: dict[str, object] = json.loads(done.stdout)
    return report


def check_everything_counted_reads_back(path: Path, on_disk: int) -> None:
    (mcap,) = path.glob("*.mcap")
    salvaged = salvage_file(mcap)
    assert salvaged.stop == "a footer without summary"  # cut back to a whole chunk + footer
    assert len(salvaged.messages) == on_disk
    info = yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["message_count"] == on_disk
    assert not (path / "metadata.yaml.tmp").exists()
    with Reader(mcap) as reader:  # rosbags reads it by scanning
        assert sum(1 for _ in reader.messages()) == on_disk
    recording = read_recording(path, required=TOPICS)
    assert recording.time.size >= on_disk // len(TOPICS) - 1


def test_a_write_past_the_file_size_limit_stops_and_keeps_every_committed_chunk(
    tmp_path: Path,
) -> None:
    path = tmp_path / "bag"
    report = run_child(path, "during", limit=150_000)
    assert "File too large" in str(report["error"]) and str(path) in str(report["error"])
    assert report["refused_after"] is True and report["closed"] is True
    on_disk = int(str(report["on_disk"]))
    assert 2_000 < on_disk < 20_000 * len(TOPICS)
    assert f"the {on_disk} messages committed" in str(report["error"])
    check_everything_counted_reads_back(path, on_disk)


def test_a_summary_that_does_not_fit_leaves_every_message_readable(tmp_path: Path) -> None:
    path = tmp_path / "bag"
    report = run_child(path, "at_close")
    assert "File too large" in str(report["close_error"])
    assert report["on_disk"] == 2_000 * len(TOPICS)
    assert not is_finished(path / "bag_0.mcap")
    check_everything_counted_reads_back(path, 2_000 * len(TOPICS))


def test_a_chunk_older_than_its_age_bound_is_committed_at_the_next_message(
    tmp_path: Path,
) -> None:
    path = tmp_path / "bag"
    recorder = new_recorder(path, max_chunk_age_s=0.05)
    record(recorder, 10)
    assert sum(f.message_count for f in recorder.files()) == 0  # a 1 MiB chunk, still open
    time.sleep(0.06)
    record(recorder, 11, start=10)
    committed = 10 * len(TOPICS) + 1  # the first message past the bound closes the chunk
    assert sum(f.message_count for f in recorder.files()) == committed
    assert len(salvage_file(path / "bag_0.mcap").messages) == committed
    recorder.close()
