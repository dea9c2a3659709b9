"""The rig's DAQ acquired over CAN: decoded samples sent once each, STALE at its deadline.

ROS-free. :class:`CanAcquisition` polls a :class:`~brake_hil.io.can_daq.CanDaq` on the
caller's thread and sends each decoded quantity once to its output, a ``(send, build)`` pair:
``send(build(stamp_ns, value))``. Nothing is ever sent again: a silent bus sends nothing, and
a frame whose sample counter does not advance (a frozen DAQ) is dropped by the DAQ.

Staleness is a deadline armed per good frame (``stale_after_s`` after it): a watchdog thread
sleeps until that absolute deadline and, unless a good frame has moved it meanwhile, calls
``on_change`` at once, so the STALE status is reported at the deadline rather than at the next
poll. The delay from the last good frame to that report is kept (:attr:`stale_reports_ms`).
Bus errors and a lost adapter change the status at the poll that saw them (polls are at most
1 ms apart).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
import threading
import time
from typing import Any

from brake_hil.errors import BrakeHilError
from brake_hil.io.can_daq import CanDaq, DaqStatus
from brake_hil.io.replay import Output
from brake_hil.runtime import set_realtime_priority, set_timer_slack
from brake_hil.topics import QUANTITY_TOPICS

__all__ = ["CanAcquisition"]


class CanAcquisition:
    """Samples of a CAN DAQ sent as they come, its status changes reported as they happen.

    Args:
        daq: the DAQ (not opened yet, or opened: acquiring opens it if needed).
        publish_measured: send every quantity the DBC carries, not ``p_i`` alone.
        on_change: called when the DAQ's status changes (from the acquiring thread or the
            watchdog's).
        realtime_priority: ``SCHED_FIFO`` priority of the watchdog thread (0: none).

    Raises:
        BrakeHilError: the DBC carries a quantity that has no contract topic.
    """

    def __init__(
        self,
        daq: CanDaq,
        publish_measured: bool,
        on_change: Callable[[], None],
        realtime_priority: int = 0,
    ) -> None:
        quantities = daq.codec.quantities
        unknown = [q for q in quantities if q not in QUANTITY_TOPICS]
        if unknown:
            raise BrakeHilError(f"{daq.codec.path}: no topic for the quantities {unknown}")
        self.daq = daq
        self.quantities = [q for q in quantities if publish_measured or q == "p_i"]
        self.published = 0  # samples with a p_i
        self.stale_reports_ms: list[float] = []  # last good frame to STALE reported (ms)
        self._on_change = on_change
        self._priority = realtime_priority
        self._status_lock = threading.Lock()
        self._last_status: DaqStatus | None = None
        self._rearm = threading.Event()

    def run(self, outputs: Mapping[str, Output], stop: threading.Event) -> None:
        """Acquire until ``stop``: open the DAQ, send each sample, close it at the end.

        ``outputs``: per quantity (of :attr:`quantities`), where its samples go.
        """
        # CPython's switch interval stays at 5 ms: at 0.5 ms (tried, for a prompter STALE) the
        # acquisition thread lost the GIL so often that a 3 s CAN run lost 400-600 of 3000
        # samples in the pty on a quiet 2-core host; the watchdog is prompt under SCHED_FIFO.
        watchdog = threading.Thread(
            target=self._watch_stale, args=(stop,), name="daq-stale", daemon=True
        )
        watchdog.start()
        with self.daq as daq:
            while not stop.is_set():
                for sample in daq.poll(timeout=0.001):
                    stamp = sample.stamp_ns
                    for quantity, value in sample.values.items():
                        route = outputs.get(quantity)
                        if route is not None:
                            route[0](route[1](stamp, value))
                    if "p_i" in sample.values:
                        self.published += 1
                if not self.report_if_changed() and not self._rearm.is_set():
                    self._rearm.set()  # fresh again (or never was): the watchdog waits for it
        self._rearm.set()
        watchdog.join(1.0)

    def report_if_changed(self) -> bool:
        """Call ``on_change`` when the DAQ's status differs from the last one; True if STALE.

        The delay of a STALE report from the last good frame is kept in
        :attr:`stale_reports_ms`.
        """
        with self._status_lock:
            daq = self.daq
            status = daq.health().status
            stale = status is DaqStatus.STALE
            if status is not self._last_status:
                self._last_status = status
                deadline = daq.stale_deadline_ns
                if stale and deadline is not None:  # kept first: the report carries it
                    since_frame = time.monotonic_ns() - deadline + daq.stale_after_s * 1e9
                    self.stale_reports_ms.append(since_frame / 1e6)
                self._on_change()
            return stale

    def _watch_stale(self, stop: threading.Event) -> None:
        """Report STALE at the deadline armed by the last good frame (its own thread).

        Sleeps until ``daq.stale_deadline_ns`` (absolute, monotonic); a good frame meanwhile
        has moved the deadline, so it sleeps again until the new one. Past an unmoved deadline
        the status is STALE: reported at once, then the watchdog waits to be re-armed by the
        acquiring thread once frames are fresh again.
        """
        set_timer_slack(1)
        set_realtime_priority(self._priority)
        daq = self.daq
        while not stop.is_set():
            deadline = daq.stale_deadline_ns
            if deadline is None:
                self._rearm.wait(0.1)
                continue
            left = deadline - time.monotonic_ns()
            if left > 0:
                stop.wait(left / 1e9)
                continue
            if daq.stale_deadline_ns != deadline:
                continue  # a frame came while we woke
            self._rearm.clear()
            self.report_if_changed()
            while not stop.is_set() and daq.stale_deadline_ns == deadline:
                self._rearm.wait(0.1)

    def status(self) -> tuple[int, str, dict[str, object]]:
        """The DAQ's diagnostic level, message and values now."""
        health = self.daq.health()
        message = f"DAQ {health.status.value}"
        if health.last_error:
            message += f": {health.last_error}"
        values: dict[str, object] = {
            **{key: value for key, value in health._asdict().items() if key != "status"},
            "stale_report_ms": self.stale_reports_ms[-1] if self.stale_reports_ms else -1.0,
            "stale_reports": len(self.stale_reports_ms),
            "published": self.published,
        }
        return health.status.diagnostic_level, message, values

    def summary(self) -> dict[str, Any]:
        """The DAQ's counters, status and STALE report delays, for a statistics file."""
        health = self.daq.health()._asdict()
        summary = {k: v for k, v in health.items() if k != "status"}
        summary["status"] = health["status"].value
        summary["stale_reports_ms"] = self.stale_reports_ms
        return summary
