"""STALE latency of the pressure source after the last CAN frame, over many stops of the bus.

The rig's DAQ is played from this process on an slcan pseudo-terminal (real slcan, python-can
in the node); the pressure source (its own process, ``mode: can``, ``stale_after_ms`` 5) reads
it. Each stop: a burst of acquisitions at 1 kHz, then silence. Two figures per stop:

* in the node: from the last good frame's arrival to the STALE status published (the node's
  own measurement, ``stale_reports_ms`` in its statistics file);
* end to end: from this process writing the last frame to the pty to the ``header.stamp`` of
  the first STALE ``pressure_source: daq`` status after it (the node's clock at publication;
  same host clock).

``--busy N`` keeps N other processes spinning (``while 1: pass``) for the whole run, as on a
shared runner. Run from the checkout::

    .venv/bin/python benchmarks/bench_stale.py --stops 200 --busy 2
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
import subprocess
import sys
import tempfile
import threading
import time
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from brake_hil.app.chain import ros_environment, start_node, stop_node  # noqa: E402
from brake_hil.io.can_daq import RigFrameCodec, SlcanPty  # noqa: E402
from brake_hil.runtime import loopback_environment  # noqa: E402

BURST, SILENCE_S = 30, 0.06


def _percentiles(values: list[float]) -> str:
    if not values:
        return "none"
    array = np.asarray(values)
    return (
        f"p50 {np.percentile(array, 50):.2f} ms, p99 {np.percentile(array, 99):.2f} ms, "
        f"max {array.max():.2f} ms (n {array.size})"
    )


def main() -> int:
    """Run the stops; print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stops", type=int, default=200)
    parser.add_argument("--busy", type=int, default=2, help="spinning processes beside it")
    parser.add_argument("--stale-after-ms", type=float, default=5.0)
    parser.add_argument(
        "--realtime-priority", type=int, default=0, help="the source's SCHED_FIFO (0: off)"
    )
    args = parser.parse_args()

    loopback_environment(os.environ)
    env = ros_environment()
    os.environ["ROS_DOMAIN_ID"] = env["ROS_DOMAIN_ID"]
    from diagnostic_msgs.msg import DiagnosticArray
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from brake_hil.nodes import common

    busy = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(args.busy)]
    work = Path(tempfile.mkdtemp(prefix="bench_stale_"))
    link = work / "rig_can"
    codec = RigFrameCodec()
    statuses: list[tuple[int, int]] = []  # (header stamp ns, level)
    rclpy.init()
    node = rclpy.create_node("bench_stale")

    def on_array(array: Any) -> None:
        for status in array.status:
            if status.name == "pressure_source: daq":
                statuses.append((common.stamp_ns(array), status.level[0]))

    node.create_subscription(
        DiagnosticArray, common.DIAGNOSTICS_TOPIC, on_array, common.DIAGNOSTICS_QOS
    )
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    stop = threading.Event()
    spinner = threading.Thread(
        target=lambda: [executor.spin_once(0.05) for _ in iter(stop.is_set, True)], daemon=True
    )
    spinner.start()
    adapter = SlcanPty(link)
    source = start_node(
        "pressure_source",
        {
            "mode": "can",
            "can_interface": "slcan",
            "can_channel": str(link),
            "stale_after_ms": args.stale_after_ms,
            "statistics_file": str(work / "source.json"),
            "realtime_priority": args.realtime_priority,
        },
        env,
        work / "logs",
    )
    stops: list[tuple[int, int]] = []  # (first frame written, last frame written), wall ns
    try:
        deadline = time.monotonic() + 60.0
        while not statuses and time.monotonic() < deadline:
            time.sleep(0.05)
        counter = 0
        for _ in range(args.stops):
            start = time.monotonic_ns()
            first = time.time_ns()
            for k in range(BURST):
                while time.monotonic_ns() < start + k * 1_000_000:
                    time.sleep(0.0002)
                adapter.send(codec.encode(counter, {"p_i": 1e6, "p_b": 1e6, "F_k": 0, "x_c": 0}))
                counter += 1
            stops.append((first, time.time_ns()))
            time.sleep(SILENCE_S)
        time.sleep(0.5)
    finally:
        stop_node(source)
        adapter.close()
        stop.set()
        spinner.join(2.0)
        for process in busy:
            process.kill()
        node.destroy_node()
        rclpy.shutdown()
    summary = json.loads((work / "source.json").read_text())
    in_node = summary["daq"]["stale_reports_ms"]
    end_to_end, missed = [], 0
    stale = sorted(stamp for stamp, level in statuses if level == common.STALE)
    for index, (_, last) in enumerate(stops):
        until = stops[index + 1][0] if index + 1 < len(stops) else last + 10**9
        found = [stamp for stamp in stale if last < stamp < until]
        if found:
            end_to_end.append((found[0] - last) / 1e6)
        else:
            missed += 1
    load = os.getloadavg()
    print(
        f"{len(stops)} stops, stale_after_ms {args.stale_after_ms:g}, {args.busy} busy "
        f"processes, SCHED_FIFO {args.realtime_priority or 'off'}, load average "
        f"{load[0]:.1f} / {load[1]:.1f}"
    )
    print(f"in the node (last good frame -> STALE published): {_percentiles(in_node)}")
    print(f"end to end (last frame written -> STALE header.stamp): {_percentiles(end_to_end)}")
    print(f"stops without a STALE before the next burst: {missed}")
    print(f"STALE reports in all (hiccups over the threshold in bursts included): {len(in_node)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
