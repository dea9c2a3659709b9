"""A recording replayed paced by its samples' stamps, what a replaying source sends (ROS-free).

:class:`Replay` reads a recording (rosbag2 directory, ``.mcap`` or ``.db3``), keeps the samples
from ``start_offset`` for ``duration`` and plays them at absolute deadlines (monotonic clock,
sleep then spin), at real time or ``rate`` times it, optionally looped: a late wake-up sends
the samples that fell due back to back, never skips one. Each sample goes to every channel's
output, a ``(send, build)`` pair: ``send(build(stamp_ns, value))`` (a ROS publisher's
``publish`` and a message builder, or anything else).

Stamps (:class:`~brake_hil.runtime.StampMode`): ``shift`` moves every recorded stamp by one
offset so the first replayed sample is stamped with the wall-clock time of its sending;
``keep`` sends the recorded stamps. Each further loop pass adds the recording's span plus
one sample interval, so stamps always increase.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
import threading
import time
from typing import Any

from brake_hil.analysis.recording import Recording
from brake_hil.errors import BrakeHilError
from brake_hil.io.recording_reader import read_recording
from brake_hil.runtime import (
    LoopStatistics,
    StampMode,
    loop_span_ns,
    replay_deadlines,
    sleep_until,
)
from brake_hil.topics import (
    AIR_PRESSURE,
    BLOCK_FORCE,
    BORE_PRESSURE,
    CALIPER_DISPLACEMENT,
    MASTER_CYLINDER_PRESSURE,
    TopicSpec,
)

__all__ = ["Follower", "Output", "Replay", "replay_channels"]

Output = tuple[Callable[[Any], object], Callable[[int, float], Any]]
"""Where one channel's samples go: ``(send, build)``, each sample ``send(build(stamp, value))``."""
Follower = Callable[[int, int], None]
"""Called after each sample with its deadline and the wake-up time (monotonic ns)."""


def replay_channels(recording: Recording, publish_measured: bool) -> dict[TopicSpec, Any]:
    """The recording's channels to publish, keyed by topic (``p_i`` first)."""
    channels: dict[TopicSpec, Any] = {MASTER_CYLINDER_PRESSURE: recording.master_cylinder_pressure}
    if publish_measured:
        for spec, values in (
            (BORE_PRESSURE, recording.bore_pressure),
            (BLOCK_FORCE, recording.block_force),
            (CALIPER_DISPLACEMENT, recording.caliper_displacement),
            (AIR_PRESSURE, recording.air_pressure),
        ):
            if values is not None:
                channels[spec] = values
    return channels


class Replay:
    """A recording's samples, ready to play at their pace.

    Args:
        path: the recording.
        stamp_mode: ``shift`` or ``keep``.
        publish_measured: play the measured outputs (and ``p_a``) too, not ``p_i`` alone.
        start_offset: seconds of the recording skipped at its start.
        duration: seconds played from there (0: to the end).

    Raises:
        BrakeHilError: no path, a bad stamp mode, an unreadable recording, or fewer than two
            samples left to play.
    """

    def __init__(
        self,
        path: str,
        stamp_mode: str,
        publish_measured: bool,
        start_offset: float = 0.0,
        duration: float = 0.0,
    ) -> None:
        if not path:
            raise BrakeHilError("replay mode needs the parameter 'recording'")
        try:
            self.stamp_mode = StampMode(stamp_mode)
        except ValueError as err:
            raise BrakeHilError(f"stamp_mode must be shift or keep, got {stamp_mode!r}") from err
        recording = read_recording(path)
        time_s = recording.time
        keep = time_s >= start_offset - 1e-9
        if duration > 0.0:
            keep &= time_s < start_offset + duration - 1e-9
        if keep.sum() < 2:
            raise BrakeHilError(
                f"{path}: start_offset {start_offset} s and duration {duration} s leave fewer "
                f"than 2 of its {time_s.size} samples ({time_s[-1]:.3f} s long)"
            )
        self.recording = recording
        self.stamps = recording.start_stamp_ns + (time_s[keep] * 1e9).round().astype("int64")
        channels = replay_channels(recording, publish_measured)
        self.values = {spec: values[keep].tolist() for spec, values in channels.items()}
        self.statistics = LoopStatistics()  # the period error of each sample's wake-up
        self.published = 0  # samples (p_i) sent
        self.passes = 0  # passes played to their end

    @property
    def specs(self) -> list[TopicSpec]:
        """The channels played, ``p_i`` first."""
        return list(self.values)

    @property
    def samples(self) -> int:
        """Samples in one pass."""
        return int(self.stamps.size)

    def play(
        self,
        outputs: Sequence[Output],
        stop: threading.Event,
        rate: float = 1.0,
        loop: bool = False,
        spin_margin_us: int = 0,
        followers: Sequence[Follower] = (),
    ) -> None:
        """Send every sample at its deadline until the end (or forever, ``loop``) or ``stop``.

        ``outputs``: one per channel, in :attr:`specs` order. ``followers`` are called after
        each sample on this thread (the sequence itself is read at each sample, so one added
        meanwhile is seen). ``spin_margin_us``: spun, not slept, before each deadline.
        """
        stamps = self.stamps
        span = loop_span_ns(stamps)
        start = time.monotonic_ns() + 1_000_000
        wall_start = time.time_ns() + (start - time.monotonic_ns())
        offset = wall_start - int(stamps[0]) if self.stamp_mode is StampMode.SHIFT else 0
        deadlines = replay_deadlines(stamps, start, rate).tolist()
        pass_duration = round(span / rate)
        stamp_list = stamps.tolist()
        columns = list(self.values.values())
        sends = [send for send, _ in outputs]
        builders = [build for _, build in outputs]
        stats = self.statistics
        spin_ns = 1000 * spin_margin_us
        while not stop.is_set():
            shift = self.passes * pass_duration
            stamp_shift = offset + self.passes * span
            for index, deadline in enumerate(deadlines):
                if stop.is_set():
                    break
                due = deadline + shift
                wake = sleep_until(due, spin_ns)
                stats.add("period_error", wake - due)
                stamp = stamp_list[index] + stamp_shift
                for column, send, build in zip(columns, sends, builders):
                    send(build(stamp, column[index]))
                self.published += 1
                for follow in followers:
                    follow(due, wake)
            else:
                self.passes += 1
                if loop:
                    continue
            break
