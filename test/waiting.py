"""Waiting in tests for what another thread or process does, by condition, not by a fixed time.

A busy shared CI runner delays every thread: a test that sleeps a fixed time and then reads
what a collector took reads too early now and then. These wait (generously) for the
condition itself.
"""

from __future__ import annotations

from collections.abc import Callable
import time


def wait_until(condition: Callable[[], object], timeout_s: float, poll_s: float = 0.02) -> bool:
    """Whether ``condition`` came true (or nonzero) within ``timeout_s`` (checked every poll).

    Every 20 ms by default: a condition that counts thousands of samples, checked every
    millisecond, would take the core the node under test needs on a 2-core runner.
    """
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() >= deadline:
            return False
        time.sleep(poll_s)
    return True


def wait_until_still(count: Callable[[], int], quiet_s: float, timeout_s: float) -> bool:
    """Whether ``count()`` stayed the same for ``quiet_s`` (s) within ``timeout_s`` (s).

    For a stream whose length is not known beforehand: its last items have arrived once no
    more come for ``quiet_s``.
    """
    deadline = time.monotonic() + timeout_s
    last, since = count(), time.monotonic()
    while time.monotonic() < deadline:
        time.sleep(0.02)
        now = count()
        if now != last:
            last, since = now, time.monotonic()
        elif time.monotonic() - since >= quiet_s:
            return True
    return False
