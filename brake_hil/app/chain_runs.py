"""The chain runs: a recording replayed through the nodes, or the rig emulator over CAN.

Both load the model file once (a bad one fails before any node starts, and the same model
checks the recorded predictions), start the nodes readers first, wait for the source's end,
stop the nodes last started first and read what they left (:class:`ChainResult`). No rclpy.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
import os
from pathlib import Path
import subprocess
import time
from typing import Any

import numpy as np

from brake_hil.analysis.recording import Recording
from brake_hil.analysis.stamp_scoring import expected_cycles
from brake_hil.app.chain_environment import (
    DEFAULT_MODEL,
    PROJECT,
    check_security,
    node_available,
    ros_environment,
)
from brake_hil.app.chain_layouts import (
    CONTAINER_STOP_S,
    DEFAULT_LAYOUT,
    LAYOUTS,
    readers_per_topic,
    start_layout,
)
from brake_hil.app.chain_processes import (
    NodeProcess,
    start_node,
    stop_node,
    wait_for_file,
    wait_until_quiet,
)
from brake_hil.app.chain_result import ChainResult, check_recorded_predictions, read_json
from brake_hil.errors import BrakeHilError
from brake_hil.io.recording_reader import read_recording
from brake_hil.live.model import LiveModel
from brake_hil.live.model_file import load_model
from brake_hil.physics.excitation import PulsingSchedule
from brake_hil.topics import (
    AIR_PRESSURE,
    MASTER_CYLINDER_PRESSURE,
    MEASURED_OUTPUTS,
    PREDICTED_OUTPUTS,
)

__all__ = ["SOURCE_MARGIN_S", "Notice", "run_can_chain", "run_chain"]

SOURCE_MARGIN_S = 100.0
"""How long past the replay's own length the source is given to end (s): its wait for its
subscribers (at most 30 s), its start delay (1 s) and its wait for their acknowledgements at
the end (``common.ACK_WAIT_AT_END_S``, 60 s)."""

Notice = Callable[[str], None]
"""Called with a one-line notice while the chain runs (what it starts, what went wrong)."""


def _ignore(message: str) -> None:
    """A notice nobody reads."""


@dataclass
class _Run:
    """One run of the chain: what it needs to start, stop and read its nodes."""

    out_dir: Path
    model: LiveModel
    env: dict[str, str]
    say: Notice
    bag_name: str | None
    expected: int
    missing: tuple[str, ...] = ()
    expected_cycles: dict[str, int] | None = None  # steady cycles the recording holds
    schedule_s: float | None = None  # the replay's length at its rate (s)
    nodes: list[NodeProcess] = field(default_factory=list)
    exit_codes: dict[str, int] = field(default_factory=dict)
    cpu_s: dict[str, float] = field(default_factory=dict)

    @property
    def logs(self) -> Path:
        """Where the nodes' logs go."""
        return self.out_dir / "logs"

    def start(self, name: str, parameters: dict[str, Any]) -> NodeProcess:
        """Start node ``name`` in its own process."""
        self.nodes.append(start_node(name, parameters, self.env, self.logs))
        return self.nodes[-1]

    def model_parameters(self, subscribers: int, **extra: Any) -> dict[str, Any]:
        """The caliper model's parameters: waits for ``subscribers`` on its outputs first."""
        return {
            "model_file": str(self.model.path),
            "mean_pressure": self.model.mean_pressure,
            "statistics_file": str(self.out_dir / "caliper_model.json"),
            **extra,
            "wait_for_subscribers": subscribers,  # comparator (and recorder) matched first
        }

    def execute(self, play: Callable[[], float]) -> ChainResult:
        """``play`` (start the nodes, wait for the source; the wall time), then stop and read."""
        wall_s = 0.0
        try:
            wall_s = play()
        finally:
            self._stop_all()
        return self._collect(wall_s)

    def _stop_all(self) -> None:
        """Stop the nodes, last started first (source, model, comparator, recorder).

        The recorder is stopped once its files stop growing (:func:`wait_until_quiet`); the
        container stops its nodes in that order itself, given ``CONTAINER_STOP_S``.
        """
        for node in reversed(self.nodes):
            if node.name == "recorder" and self.bag_name is not None:
                wait_until_quiet(self.out_dir / self.bag_name)
            cpu = node.cpu_seconds()
            if cpu is not None:
                self.cpu_s[node.name] = cpu
            timeout_s = CONTAINER_STOP_S if node.is_container else 10.0
            self.exit_codes[node.name] = stop_node(node, timeout_s)

    def _collect(self, wall_s: float) -> ChainResult:
        """Read what the nodes left (summaries, the bag) and check the bag."""
        failed = {name: code for name, code in self.exit_codes.items() if code != 0}
        if failed:
            self.say(f"nodes exited with errors: {failed}; logs in {self.logs}")
        out_dir, bag, check = self.out_dir, None, None
        if self.bag_name is not None and (out_dir / self.bag_name / "metadata.yaml").is_file():
            bag = out_dir / self.bag_name
            try:
                check = check_recorded_predictions(bag, self.model)
            except BrakeHilError as err:
                self.say(f"the recording cannot be checked: {err}")
        return ChainResult(
            out_dir=out_dir,
            comparator=read_json(out_dir / "comparator.json"),
            model=read_json(out_dir / "caliper_model.json"),
            bag=bag,
            check=check,
            missing=self.missing,
            exit_codes=self.exit_codes,
            cpu_s=self.cpu_s,
            wall_s=wall_s,
            logs=self.logs,
            source=read_json(out_dir / "pressure_source.json"),
            expected=self.expected,
            expected_cycles=self.expected_cycles,
            schedule_s=self.schedule_s,
            load=(os.getloadavg()[0], os.cpu_count() or 1),
        )


def _prepare(
    model_file: Path,
    mean_pressure: float,
    out_dir: Path,
    domain_id: int | None,
    progress: Notice | None,
    bag_prefix: str | None,
    expected: int,
) -> _Run:
    """Load the model (once: a bad file fails here, with one line) and the environment."""
    model = load_model(model_file, mean_pressure)
    env = ros_environment(domain_id)
    check_security(env)
    stamp = datetime.now(UTC).strftime("%Y_%m_%d-%H_%M_%S")
    bag_name = None if bag_prefix is None else bag_prefix + stamp
    return _Run(out_dir, model, env, progress or _ignore, bag_name, expected)


def run_chain(
    recording: Path,
    model_file: Path = DEFAULT_MODEL,
    out_dir: Path = PROJECT / "out" / "chain",
    rate: float = 1.0,
    domain_id: int | None = None,
    progress: Notice | None = None,
    recorder: bool = True,
    realtime_priority: int = 0,
    layout: str = DEFAULT_LAYOUT,
) -> ChainResult:
    """Run the chain on ``recording`` once (see :mod:`brake_hil.app.chain`).

    Args:
        recording: the recording the source replays (``p_i`` and the measured outputs).
        model_file: the caliper model's model file (rig YAML or ``improved_model.json``).
        out_dir: summaries, the MCAP and ``logs/`` go here.
        rate: replay rate factor.
        domain_id: ``ROS_DOMAIN_ID`` of the run (``None``: one chosen for it).
        progress: called with each notice while the chain runs.
        recorder: record the run to MCAP (when the recorder node exists).
        realtime_priority: ``SCHED_FIFO`` priority of the source's and the model's loop
            threads (0: none).
        layout: which nodes share a process (``LAYOUTS``).

    Returns:
        What the nodes left: summaries, exit codes, CPU times, the checked recording.

    Raises:
        BrakeHilError: a bad recording or model file (before any node starts).
    """
    if layout not in LAYOUTS:
        raise BrakeHilError(f"unknown layout {layout!r} (layouts: {', '.join(LAYOUTS)})")
    source = read_recording(recording, required=(MASTER_CYLINDER_PRESSURE, *MEASURED_OUTPUTS))
    mean_pressure = float(np.mean(source.master_cylinder_pressure))
    has_recorder = recorder and node_available("recorder")
    run = _prepare(
        model_file,
        mean_pressure,
        out_dir,
        domain_id,
        progress,
        "chain_" if has_recorder else None,
        int(source.time.size),
    )
    if recorder and not has_recorder:
        run.missing = ("recorder",)
        run.say("recorder node not available: running without recording")
    length_s = float(source.time[-1])
    run.expected_cycles = _expected_cycles(source)
    run.schedule_s = length_s / rate
    run.say(
        f"chain on {recording} ({length_s:.1f} s at rate {rate:g}), model {model_file}, "
        f"ROS_DOMAIN_ID {run.env['ROS_DOMAIN_ID']}, layout {layout}"
    )
    readers = readers_per_topic(layout, has_recorder)
    plan: list[tuple[str, dict[str, Any]]] = []  # readers before their writers
    if run.bag_name is not None:
        plan.append(("recorder", {"output_dir": str(out_dir), "bag_name": run.bag_name}))
    plan.append(("comparator", {"summary_file": str(out_dir / "comparator.json")}))
    model = run.model_parameters(readers["predicted"], realtime_priority=realtime_priority)
    plan.append(("caliper_model", model))
    air = [f"{AIR_PRESSURE.name}:1"] if has_recorder and source.air_pressure is not None else []
    source_parameters = {
        "recording": str(recording),
        "statistics_file": str(out_dir / "pressure_source.json"),
        "rate": float(rate),
        "exit_at_end": True,
        "wait_for_subscribers": 0,
        "wait_for_topics": _source_waits(readers) + air,
        "wait_timeout": 30.0,
        "start_delay": 1.0,
        "realtime_priority": realtime_priority,
    }
    plan.append(("pressure_source", source_parameters))
    timeout_s = length_s / rate + SOURCE_MARGIN_S
    return run.execute(lambda: _replay(run, plan, layout, timeout_s))


CONSUMERS_BELOW = 10
"""With ``realtime_priority`` P, a one-process layout's other threads (the comparator, the
recorder, the middleware) run under ``SCHED_FIFO`` at P - 10 (at least 1)."""


def _replay(
    run: _Run, plan: Sequence[tuple[str, dict[str, Any]]], layout: str, timeout_s: float
) -> float:
    """Start ``plan`` as ``layout`` says and wait for the source's end; the wall time (s).

    With the source in a container the launcher waits for the source's statistics file
    (written as its replay ends) instead of its exit.
    """
    source_done = run.out_dir / "pressure_source.json"  # written as the source ends
    source_done.unlink(missing_ok=True)
    if "pressure_source" in LAYOUTS[layout]:  # the source runs in a container
        loops = max(int(parameters.get("realtime_priority", 0)) for _, parameters in plan)
        consumers = max(1, loops - CONSUMERS_BELOW) if loops > 0 else 0
        run.nodes.extend(
            start_layout(plan, run.env, run.logs, layout, container_priority=consumers)
        )
        container = next(node for node in run.nodes if node.runs("pressure_source"))
        started = time.monotonic()
        if not wait_for_file(source_done, container, timeout_s):
            code = container.returncode()
            run.say(
                f"pressure_source did not finish in time: stopping {container.name}"
                if code is None
                else f"{container.name} exited with status {code} before the source finished"
            )
    else:
        for name, parameters in plan:
            run.start(name, parameters)
        started = time.monotonic()
        _wait_for_exit(run, run.nodes[-1], timeout_s)
    time.sleep(1.0)  # the model drains, the comparator scores its last cycle
    return time.monotonic() - started


def _wait_for_exit(run: _Run, node: NodeProcess, timeout_s: float) -> None:
    """Wait for ``node`` to end by itself (at most ``timeout_s``); say so when it did not."""
    try:
        node.process.wait(timeout_s)
    except subprocess.TimeoutExpired:
        run.say(f"{node.name} did not finish in time: stopping it")


def _expected_cycles(recording: Recording) -> dict[str, int]:
    """Steady cycles per channel the comparator scores on ``recording`` when it keeps up."""
    stamps = np.round(recording.time * 1e9).astype(np.int64)
    measured = {c: v for c, v in recording.measured().items() if v is not None}
    return expected_cycles(stamps, measured)


def _source_waits(readers: dict[str, int]) -> list[str]:
    """The pressure source's ``wait_for_topics``: each topic's own subscriptions.

    The model takes p_i, the comparator the measured outputs and the predictions, the recorder
    everything: ``readers`` per kind of topic (:func:`readers_per_topic`).
    """
    return [
        f"{MASTER_CYLINDER_PRESSURE.name}:{readers['p_i']}",
        *(f"{spec.name}:{readers['measured']}" for spec in MEASURED_OUTPUTS),
        *(f"{spec.name}:{readers['predicted']}" for spec in PREDICTED_OUTPUTS),
    ]


def run_can_chain(
    rig_file: Path = DEFAULT_MODEL,
    effects: Sequence[str] = (),
    model_file: Path = DEFAULT_MODEL,
    out_dir: Path = PROJECT / "out" / "chain_can",
    pulsing_s: float = 5.0,
    domain_id: int | None = None,
    progress: Notice | None = None,
) -> ChainResult:
    """The chain against the rig emulator over CAN, without hardware.

    rig_emulator plays a virtual-rig run of ``rig_file`` (with ``effects``) in real time as
    the DBC's CAN frames on an slcan pseudo-terminal; pressure_source reads them as a DAQ
    (mode ``can``) and publishes the measured topics; then model, comparator and recorder as
    in :func:`run_chain`.

    Args:
        rig_file: the truth rig the emulator simulates.
        effects: virtual-rig effects, ``NAME[=STRENGTH]`` each.
        model_file: the caliper model's model file.
        out_dir: summaries, the MCAP, the slcan link and ``logs/`` go here.
        pulsing_s: seconds of 5 Hz pulsing the emulator plays.
        domain_id: ``ROS_DOMAIN_ID`` of the run (``None``: one chosen for it).
        progress: called with each notice while the chain runs.

    Returns:
        What the nodes left, as :func:`run_chain`.

    Raises:
        BrakeHilError: a bad model file (before any node starts).
    """
    schedule = PulsingSchedule((1.38e6,), pulsing_s=pulsing_s)  # what the emulator plays
    mean_pressure = schedule.segments[0].mean
    run = _prepare(
        model_file, mean_pressure, out_dir, domain_id, progress, "chain_can_", schedule.samples
    )
    link = out_dir / "rig_can"
    out_dir.mkdir(parents=True, exist_ok=True)
    link.unlink(missing_ok=True)
    run.say(
        f"chain over CAN: rig_emulator ({rig_file}, effects {list(effects) or 'none'}) -> "
        f"slcan {link} -> pressure_source -> model {model_file}, "
        f"ROS_DOMAIN_ID {run.env['ROS_DOMAIN_ID']}"
    )
    emulator = {
        "rig_file": str(rig_file),
        "effects": list(effects) or [""],
        "max_pressures": list(schedule.max_pressures),
        "pulsing_s": schedule.pulsing_s,
        "loop": False,
        "output": "can",
        "can_link_path": str(link),
        "wait_for_subscribers": 1,  # the pressure source has opened the pty
        "wait_timeout_s": 60.0,
        "start_delay_s": 1.0,
    }
    source = {
        "mode": "can",
        "can_interface": "slcan",
        "can_channel": str(link),
        "can_bitrate": 1_000_000,
        "statistics_file": str(out_dir / "pressure_source.json"),
        # the emulator starts once this source opens the port: open it only once the model
        # and the recorder take p_i (discovery can take over a second on a busy host)
        "wait_for_subscribers": 0,
        "wait_for_topics": _source_waits(readers_per_topic("processes")),
        "wait_timeout": 30.0,
    }
    return run.execute(lambda: _emulate(run, emulator, source, pulsing_s + 120.0))


def _emulate(
    run: _Run, emulator: dict[str, Any], source: dict[str, Any], timeout_s: float
) -> float:
    """Start the nodes and the emulator, wait for the emulator's end; the wall time (s)."""
    assert run.bag_name is not None
    run.start("recorder", {"output_dir": str(run.out_dir), "bag_name": run.bag_name})
    run.start("comparator", {"summary_file": str(run.out_dir / "comparator.json")})
    run.start("caliper_model", run.model_parameters(2))
    player = run.start("rig_emulator", emulator)
    run.start("pressure_source", source)
    started = time.monotonic()
    _wait_for_exit(run, player, timeout_s)
    time.sleep(1.0)
    return time.monotonic() - started
