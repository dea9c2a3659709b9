"""The rig_emulator node's ROS side: a virtual rig played in real time.

What the node does, its topics and parameters: :mod:`brake_hil.nodes.rig_emulator`, the
entry point (``python -m brake_hil.nodes.rig_emulator``), which answers ``--help`` without
importing this.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
import shutil
import tempfile
import threading
import time
from typing import Any, NamedTuple

from diagnostic_msgs.msg import DiagnosticArray
import numpy as np
from rclpy.node import Node

from brake_hil.errors import BrakeHilError
from brake_hil.nodes import common
from brake_hil.nodes.rig_emulator import NAME
from brake_hil.nodes.settings import RigEmulatorSettings
from brake_hil.physics.excitation import DEFAULT_SCHEDULE, PulsingSchedule
from brake_hil.physics.lti_model import ModelInput, discretize, simulate, state_space
from brake_hil.physics.measurement import SENSORS, measure
from brake_hil.physics.parameters import derive_parameters
from brake_hil.physics.rig import Rig, load_rig
from brake_hil.runtime import DeadlineLoop, LoopStatistics, Tick
from brake_hil.topics import QUANTITY_TOPICS
from brake_hil.types import FloatArray

SAMPLE_PERIOD_NS = 1_000_000


_COUNTERS = ("ticks", "late_ticks", "overruns", "ticks_skipped")


class EmulatedRun(NamedTuple):
    """What the emulator plays: measured signals at 1 kHz (SI), by channel key."""

    measured: dict[str, FloatArray]  # p_i, p_b, F_k, x_c (Pa, Pa, N, m), and p_a when present
    label: str

    @property
    def samples(self) -> int:
        """Number of samples."""
        return int(next(iter(self.measured.values())).size)


def precompute_run(
    rig: Rig,
    simulator: str = "virtual_rig",
    effects: Sequence[str] = (),
    schedule: PulsingSchedule = DEFAULT_SCHEDULE,
    seed: int = 0,
) -> EmulatedRun:
    """The run to play: the seed's ramp-then-pulse input through a simulator, as measured.

    The input is in Pa (``schedule``); the DAQ measures the run (noise, 16-bit quantisation,
    :mod:`brake_hil.physics.measurement`).

    ``simulator``: ``virtual_rig`` (:func:`brake_hil.virtual_rig.simulate_rig`, with
    ``effects`` as ``parse_effect`` texts) or ``lti`` (:func:`brake_hil.physics.lti_model.simulate`
    of the seed's model; ``effects`` must be empty).

    Raises:
        BrakeHilError: an unknown simulator or effect, effects with ``lti``, a failed run.
    """
    if simulator == "virtual_rig":
        from brake_hil.virtual_rig import parse_effect, simulate_rig
        from brake_hil.virtual_rig.excitation import seed_pulsing_from

        excitation = seed_pulsing_from(schedule)
        run = simulate_rig(rig, [parse_effect(text) for text in effects], excitation, seed=seed)
        return EmulatedRun(dict(run.measured), f"virtual rig: {excitation.label}")
    if simulator != "lti":
        raise BrakeHilError(f"simulator must be 'virtual_rig' or 'lti', got {simulator!r}")
    if effects:
        raise BrakeHilError(f"the lti simulator has no effects; got {list(effects)}")
    _, pressure = schedule.profile()
    model = discretize(state_space(derive_parameters(rig), ModelInput.MASTER_CYLINDER_PRESSURE))
    p_b, f_k, x_c = simulate(model, pressure)[:3]
    rng = np.random.default_rng(seed)
    true = {"p_i": pressure, "p_b": p_b, "F_k": f_k, "x_c": x_c}
    measured = {key: measure(values, SENSORS[key], rng) for key, values in true.items()}
    return EmulatedRun(measured, f"lti model: pulsing {schedule.pulsing_hz:g} Hz")


class _CanOutput:
    """Frames of each sample to an slcan pseudo-terminal or a python-can bus.

    ``hold_s`` (s, slcan pty only): how long a frame waits for room while the pty's reader
    lags before it is dropped; after a drop none waits until a frame fits again (see the
    module doc).
    """

    def __init__(
        self, interface: str, channel: str, bitrate: int, link: str, dbc: str, hold_s: float = 0.0
    ) -> None:
        from brake_hil.io.can_daq import RigFrameCodec, SlcanPty

        self.codec = RigFrameCodec(dbc or None)
        self.hold_s = hold_s
        self.reader_stalled = False  # a frame waited hold_s in vain; none waits until one fits
        self.closed = False
        self.pty: Any = None
        self.bus: Any = None
        self.private: Path | None = None  # the private folder of the link, when we made it
        if interface == "slcan_pty":
            if not link:
                self.private = Path(tempfile.mkdtemp(prefix="brake_hil_rig_can_"))
                link = str(self.private / "rig_can")
            self.pty = SlcanPty(link)
            self.where = f"slcan pty {self.pty.device_path} (link {link})"
        else:
            import can

            self.bus = can.Bus(interface=interface, channel=channel, bitrate=bitrate)
            self.where = f"{interface} {channel}"
        self.sent = 0
        self.errors = 0

    def send(self, counter: int, values: dict[str, float], timestamp: float) -> None:
        frames = self.codec.encode(counter, values, timestamp)
        if self.pty is not None:
            for frame in frames:
                if self.closed:  # closing: the pty goes, the playback thread may still be here
                    return
                written = self.pty.send([frame], 0.0 if self.reader_stalled else self.hold_s)
                self.reader_stalled = not written
                self.sent += written
            return
        for frame in frames:
            try:
                self.bus.send(frame, timeout=0.001)
                self.sent += 1
            except Exception:  # noqa: BLE001 - a full or lost bus drops the frame, counted
                self.errors += 1

    @property
    def dropped(self) -> int:
        return int(self.pty.dropped) + self.errors if self.pty is not None else self.errors

    def close(self) -> None:
        self.closed = True
        if self.pty is not None:
            self.pty.close()
            if self.private is not None:
                shutil.rmtree(self.private, ignore_errors=True)
        if self.bus is not None:
            self.bus.shutdown()


class RigEmulatorNode(Node):
    """Plays a precomputed virtual-rig run at 1 kHz on topics and/or CAN."""

    def __init__(self) -> None:
        super().__init__(NAME)
        self.settings = settings = common.declare_settings(self, RigEmulatorSettings)
        self.output = settings.output
        if self.output not in ("topics", "can", "both"):
            raise BrakeHilError(f"output must be topics, can or both, got {self.output!r}")

        rig = load_rig(settings.rig_file or common.config_path("rig_default.yaml"))
        started = time.perf_counter()
        self.run = precompute_run(
            rig,
            settings.simulator,
            [text for text in settings.effects if text],
            settings.schedule,
            settings.seed,
        )
        self.get_logger().info(
            f"{self.run.label}: {self.run.samples} samples computed in "
            f"{time.perf_counter() - started:.2f} s"
        )
        self._keys = list(self.run.measured)
        self._columns = np.column_stack([self.run.measured[k] for k in self._keys]).tolist()

        self._outputs: list[tuple[Any, common.MessageBuilder]] = []
        if self.output in ("topics", "both"):
            for key in self._keys:
                spec = QUANTITY_TOPICS[key]
                publisher = self.create_publisher(
                    common.message_class(spec), spec.name, common.SAMPLE_QOS
                )
                self._outputs.append((publisher, common.MessageBuilder(spec, settings.frame_id)))
        self._can: _CanOutput | None = None
        if self.output in ("can", "both"):
            self._can = _CanOutput(
                settings.can_interface,
                settings.can_channel,
                settings.can_bitrate,
                settings.can_link_path,
                settings.dbc_file,
                settings.can_hold_s,
            )
            self.get_logger().info(f"CAN frames on {self._can.where}")
        self._diagnostics = self.create_publisher(
            DiagnosticArray, common.DIAGNOSTICS_TOPIC, common.DIAGNOSTICS_QOS
        )
        self.create_timer(settings.diagnostics_period_s, self._report)

        self.exit_requested = threading.Event()
        self.sent = 0  # samples played
        self.passes = 0
        self.statistics = LoopStatistics()
        self._wall_minus_monotonic = time.time_ns() - time.monotonic_ns()
        self._start_delay_ns = round(settings.start_delay_s * 1e9)
        self._first_deadline = 0
        self._loop = DeadlineLoop(
            self._tick,
            SAMPLE_PERIOD_NS,
            statistics=self.statistics,
            on_error=self._failed,
            name="rig-emulator",
        )
        self._waiting_since = time.monotonic()
        self._wait_timer = self.create_timer(0.05, self._start_when_subscribed)

    def _start_when_subscribed(self) -> None:
        """Start playing ``start_delay_s`` after every topic has ``wait_for_subscribers`` readers.

        Or ``start_delay_s`` after the timeout.
        """
        wait_for = self.settings.wait_for_subscribers
        ready = all(p.get_subscription_count() >= wait_for for p, _ in self._outputs)
        pty = self._can.pty if self._can is not None else None
        if wait_for > 0 and pty is not None:  # CAN on a pty: its reader has opened it
            ready = pty.poll_reader() and ready
        waited = time.monotonic() - self._waiting_since
        if not ready and waited < self.settings.wait_timeout_s:
            return
        if not ready:
            self.get_logger().warning(f"starting without subscribers after {waited:.1f} s")
        self._wait_timer.cancel()
        self._first_deadline = time.monotonic_ns() + self._start_delay_ns
        self._loop.start(self._first_deadline)

    def _tick(self, tick: Tick) -> None:
        """Play every sample due by this tick (catch-up after a late wake-up)."""
        samples = len(self._columns)
        while self.sent <= tick.slot:
            k = self.sent
            index = k % samples
            if index == 0 and k:
                self.passes += 1
                if not self.settings.loop:
                    self._loop.stop(0)
                    self.exit_requested.set()
                    return
            row = self._columns[index]
            stamp = self._first_deadline + k * SAMPLE_PERIOD_NS + self._wall_minus_monotonic
            for (publisher, build), value in zip(self._outputs, row):
                publisher.publish(build(stamp, value))
            if self._can is not None:
                self._can.send(k, dict(zip(self._keys, row)), stamp / 1e9)
            self.sent = k + 1

    def _failed(self, err: BaseException) -> None:
        self.get_logger().error(f"playback stopped: {type(err).__name__}: {err}")
        self.exit_requested.set()

    def _report(self) -> None:
        window = self.statistics.take_window()
        values: list[tuple[str, object]] = [
            ("run", self.run.label),
            ("samples_sent", self.sent),
            ("passes", self.passes),
            ("output", self.output),
            *common.timing_values({"period_error": window["period_error"]}),
            *((k, v) for k, v in self.statistics.counters.as_dict().items() if k in _COUNTERS),
        ]
        level = common.OK
        if self._can is not None:
            values += [("can", self._can.where), ("can_frames_sent", self._can.sent)]
            values.append(("can_frames_dropped", self._can.dropped))
        if self._loop.error is not None:
            level = common.ERROR
        status = common.diagnostic_status(f"{NAME}: playback", level, "playing", values)
        self._diagnostics.publish(common.diagnostic_array(self, [status]))

    def close(self) -> None:
        """Stop playing and release the CAN output."""
        self._loop.stop()
        if self._can is not None:
            self._can.close()


def main(args: list[str] | None = None) -> int:
    """The node's process (its help answered by the entry point).

    Play until SIGINT/SIGTERM (or the end, ``loop: false``).
    """

    def run(node: RigEmulatorNode) -> bool:
        common.spin_until_signal(node, node.exit_requested)
        return True

    return common.run_node(NAME, args, RigEmulatorNode, (BrakeHilError, OSError), run)
