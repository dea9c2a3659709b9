"""Speed of writing and reading a recording, against copying the same bytes, in one run.

An 18 s recording at 1 kHz of the seven sample topics (126 000 messages, the synthetic run the
I/O tests use) is written as a rosbag2 MCAP directory and read back through
:func:`~brake_hil.io.recording_reader.read_recording`; the reference is a plain copy of the
files written (what the disk and the page cache cost alone). Run from the checkout::

    .venv/bin/python benchmarks/bench_io.py --repeats 5
"""

from __future__ import annotations

import argparse
from pathlib import Path
import shutil
import statistics
import sys
import tempfile
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "test" / "io"))

from conftest import synthetic_run  # noqa: E402

from brake_hil.io.recording_reader import read_recording  # noqa: E402
from brake_hil.io.recording_writer import write_recording  # noqa: E402


def main() -> None:
    """Print the median write, read and copy times (s) and the ratios to the copy."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=18.0, help="recording length (s)")
    args = parser.parse_args()
    time_s, channels = synthetic_run(duration=args.seconds)
    writes, reads, copies = [], [], []
    for repeat in range(args.repeats):
        with tempfile.TemporaryDirectory() as scratch:
            root = Path(scratch)
            started = time.perf_counter()
            bag = write_recording(root / "bag", time_s, channels)
            writes.append(time.perf_counter() - started)
            started = time.perf_counter()
            recording = read_recording(bag)
            reads.append(time.perf_counter() - started)
            assert recording.time.size == time_s.size
            started = time.perf_counter()
            shutil.copytree(bag, root / f"copy-{repeat}")
            copies.append(time.perf_counter() - started)
    write, read, copy = (statistics.median(v) for v in (writes, reads, copies))
    messages = len(channels) * time_s.size
    print(f"recording: {args.seconds:g} s at 1 kHz, {messages} messages; {args.repeats} repeats")
    print(f"write  {write:.3f} s  ({write / copy:.0f}x the copy)")
    print(f"read   {read:.3f} s  ({read / copy:.0f}x the copy)")
    print(f"copy   {copy:.4f} s  (reference)")


if __name__ == "__main__":
    main()
