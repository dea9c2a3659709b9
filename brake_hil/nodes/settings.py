"""The nodes' ROS parameters: one frozen dataclass per node, each field a parameter.

A field's name is the parameter's name, its type the parameter's type (lists are tuples), its
default the parameter's default, and its metadata the unit and description
(:func:`parameter`). :func:`brake_hil.nodes.common.declare_settings` declares every field as
a read-only ROS parameter (description and unit in its ``ParameterDescriptor``) and returns
the dataclass filled with the values the node was started with. The params files
``config/nodes.yaml``, ``config/recorder.yaml`` and ``config/rig_emulator.yaml`` list the
same parameters with the same defaults (``test/nodes/test_settings.py`` checks them).

A default that names a file of the package's ``config/`` (``package_file``) is written as the
params files write it (``config/brake_rig.dbc``: relative to the working directory); the node
declares it as that file in the checkout or the install (``common.config_path``), so the node
finds it from any working directory.

This module imports no ROS: the settings can be read, documented and checked without rclpy.
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass, field, fields
from pathlib import PurePosixPath
import re
import typing
from typing import TYPE_CHECKING, Any, NamedTuple

from brake_hil.analysis.stamp_scoring import Thresholds
from brake_hil.physics.excitation import DEFAULT_SCHEDULE, PulsingSchedule
from brake_hil.physics.parameters import DEFAULT_MEAN_PRESSURE
from brake_hil.runtime import HoldMode, StampMode

if TYPE_CHECKING:
    from _typeshed import DataclassInstance

__all__ = [
    "CaliperModelSettings",
    "ComparatorSettings",
    "NODE_SETTINGS",
    "ParameterSpec",
    "PressureSourceSettings",
    "RecorderSettings",
    "RigEmulatorSettings",
    "help_text",
    "parameter",
    "parameter_specs",
]

_THRESHOLDS = Thresholds()


def parameter(
    default: Any, description: str, unit: str = "", *, package_file: bool = False
) -> Any:
    """A settings field: a ROS parameter with its default, description and unit.

    Args:
        default: the parameter's default (a tuple for an array parameter).
        description: what it sets, for the ``ParameterDescriptor`` and the docs.
        unit: its unit (``"s"``, ``"Pa"``, ...); empty for none.
        package_file: the default is a file of the package's ``config/`` (see the module).
    """
    metadata = {"description": description, "unit": unit, "package_file": package_file}
    return field(default=default, metadata=metadata)


class ParameterSpec(NamedTuple):
    """One ROS parameter of a settings dataclass."""

    name: str
    kind: Any  # the field's type: bool, int, float, str, tuple[str, ...], tuple[float, ...]
    default: Any
    description: str
    unit: str
    package_file: bool

    @property
    def text(self) -> str:
        """The description with its unit, for the ``ParameterDescriptor``."""
        return f"{self.description} ({self.unit})" if self.unit else self.description

    @property
    def package_file_name(self) -> str:
        """The file's name in ``config/`` of a ``package_file`` default."""
        return PurePosixPath(self.default).name

    def convert(self, value: Any) -> Any:
        """A parameter value as the field's type (an array parameter's list as a tuple)."""
        if typing.get_origin(self.kind) is tuple:
            (item, _) = typing.get_args(self.kind)
            return tuple(item(v) for v in value)
        return self.kind(value)


def parameter_specs(settings: type[DataclassInstance]) -> tuple[ParameterSpec, ...]:
    """The ROS parameters of a settings dataclass, in field order."""
    hints = typing.get_type_hints(settings)
    specs = []
    for item in fields(settings):
        if item.default is MISSING:
            raise TypeError(f"{settings.__name__}.{item.name} has no default")
        specs.append(
            ParameterSpec(
                item.name,
                hints[item.name],
                item.default,
                item.metadata["description"],
                item.metadata["unit"],
                item.metadata["package_file"],
            )
        )
    return tuple(specs)


@dataclass(frozen=True)
class PressureSourceSettings:
    """Parameters of the ``pressure_source`` node (``config/nodes.yaml``).

    ``realtime_priority`` > 0 runs the replay/acquisition thread under SCHED_FIFO at that
    priority and the node's other threads one below. ``spin_margin_us``: replay pacing needs
    no tighter timing than the kernel's wake-up. A replay waits (at most ``wait_timeout``)
    until every published topic has ``wait_for_subscribers`` subscribers and every topic of
    ``wait_for_topics`` (``/topic`` or ``/topic:N``) has one (or N), then ``start_delay``. In
    ``can`` mode the same wait, when asked for, comes before the DAQ is opened (a rig or an
    emulator that starts sending once its port is open sends to a matched graph). ``can_log``
    replays a lab's CAN log (:class:`~brake_hil.io.can_log.CanLogReplay`) through the DBC with
    the ``can`` mode's checks, paced by ``rate``, stamped per ``stamp_mode``, after the same
    wait as a replay.
    """

    mode: str = parameter(
        "replay", "replay: a recording; can: the rig's DAQ over CAN; can_log: a lab's CAN log"
    )
    publish_measured: bool = parameter(True, "also publish p_b, F_k, x_c (and p_a) when present")
    frame_id: str = parameter("caliper", "header.frame_id of every message")
    spin_margin_us: int = parameter(
        50, "sleep until this long before each deadline, then spin", "us"
    )
    realtime_priority: int = parameter(0, "SCHED_FIFO priority of the worker thread; 0: off")
    diagnostics_period: float = parameter(1.0, "diagnostics period", "s")
    statistics_file: str = parameter("", "counts and replay timing JSON at shutdown; empty: none")
    recording: str = parameter("", "replay: rosbag2 directory, .mcap or .db3 (required)")
    rate: float = parameter(1.0, "replay, can_log: rate factor (2.0 plays twice as fast)")
    loop: bool = parameter(False, "replay: start again at the end (stamps keep increasing)")
    start_offset: float = parameter(0.0, "replay: skip this much of the recording", "s")
    duration: float = parameter(0.0, "replay: play this long; 0: to the end", "s")
    stamp_mode: str = parameter(
        StampMode.SHIFT.value,
        "replay, can_log: shift (first sample stamped now, spacing kept) or keep (recorded)",
    )
    exit_at_end: bool = parameter(False, "replay, can_log: exit when the replay ends")
    wait_for_subscribers: int = parameter(0, "start once each topic has this many")
    wait_for_topics: tuple[str, ...] = parameter(
        ("",), 'and these topics ("/topic" or "/topic:N"); [""]: none'
    )
    wait_timeout: float = parameter(10.0, "start anyway after this wait", "s")
    start_delay: float = parameter(
        0.5, "replay, can_log: delay after the wait, before the first sample", "s"
    )
    can_interface: str = parameter("virtual", "can: python-can interface (socketcan, slcan, ...)")
    can_channel: str = parameter("brake_hil", "can: python-can channel (slcan: serial device)")
    can_bitrate: int = parameter(1_000_000, "can: CAN bitrate", "bit/s")
    dbc_file: str = parameter(
        "config/brake_rig.dbc", "can, can_log: CAN database", package_file=True
    )
    stale_after_ms: float = parameter(
        5.0, "can, can_log: STALE after this long without a good frame", "ms"
    )
    can_sleep_after_open: float = parameter(
        0.0, "can: wait after opening (slcan only: some USB adapters reset)", "s"
    )
    can_log: str = parameter("", "can_log: BLF, ASC, TRC or candump .log file (required)")


@dataclass(frozen=True)
class CaliperModelSettings:
    """Parameters of the ``caliper_model`` node (``config/nodes.yaml``).

    ``model_file`` is a rig YAML with optional ``model:`` overrides (or any kind
    :mod:`brake_hil.live.model_file` loads, e.g. ``improved_model.json``); the chain passes
    the replayed recording's mean ``p_i`` as ``mean_pressure``. ``hold_mode``: ``report``
    invents nothing; ``hold`` free-runs on the last input once SILENT, one step a period.
    ``realtime_priority`` > 0 runs the loop thread under SCHED_FIFO and the middleware's
    receive threads one above it (needs CAP_SYS_NICE).
    """

    model_file: str = parameter(
        "config/rig_default.yaml", "rig YAML or model file", package_file=True
    )
    mean_pressure: float = parameter(
        DEFAULT_MEAN_PRESSURE, "mean p_i the coefficients are derived at (eq. 18 air)", "Pa"
    )
    loop_period: float = parameter(0.001, "tick period", "s")
    spin_margin_us: int = parameter(
        150, "sleep until this long before each deadline, then spin", "us"
    )
    phase_lock: bool = parameter(True, "tick just after the input's usual arrival phase")
    input_late_ms: float = parameter(
        5.0, "input LATE (WARN) after this long without a sample", "ms"
    )
    input_silent_ms: float = parameter(
        50.0, "input SILENT (ERROR) after this long without a sample", "ms"
    )
    hold_mode: str = parameter(
        HoldMode.REPORT.value, "report: invent nothing; hold: free-run on the last input"
    )
    frame_id: str = parameter("caliper", "header.frame_id of the predictions")
    diagnostics_period: float = parameter(1.0, "diagnostics period", "s")
    realtime_priority: int = parameter(0, "SCHED_FIFO priority of the loop thread; 0: off")
    statistics_file: str = parameter("", "whole-run timing JSON at shutdown; empty: none")
    wait_for_subscribers: int = parameter(
        0, "subscribe to p_i once each prediction publisher has matched this many readers"
    )
    paired_with_source: bool = parameter(
        False,
        "step on the replaying pressure_source's thread, right after each sample it publishes "
        "(in one container with it; the loop's own thread takes over when the replay ends)",
    )


@dataclass(frozen=True)
class ComparatorSettings:
    """Parameters of the ``comparator`` node (``config/nodes.yaml``).

    A channel's level is WARN or ERROR when its window's ``|ptp ratio - 100 %|``,
    ``|tau / T|`` (%) or NRMSE is past the threshold
    (:class:`~brake_hil.analysis.stamp_scoring.Thresholds`, whose defaults these are).
    """

    excitation_hz: float = parameter(
        DEFAULT_SCHEDULE.pulsing_hz, "excitation frequency: one cycle = 1 / excitation_hz", "Hz"
    )
    window_cycles: int = parameter(10, "rolling window", "cycles")
    sample_period: float = parameter(0.001, "sample period", "s")
    ptp_ratio_warn_pct: float = parameter(
        _THRESHOLDS.ptp_ratio_warn_pct, "|ptp ratio - 100 %| above: WARN", "%"
    )
    ptp_ratio_error_pct: float = parameter(
        _THRESHOLDS.ptp_ratio_error_pct, "|ptp ratio - 100 %| above: ERROR", "%"
    )
    tau_over_T_warn_pct: float = parameter(
        _THRESHOLDS.tau_over_T_warn_pct, "|tau / T| above: WARN", "%"
    )
    tau_over_T_error_pct: float = parameter(
        _THRESHOLDS.tau_over_T_error_pct, "|tau / T| above: ERROR", "%"
    )
    nrmse_warn: float = parameter(_THRESHOLDS.nrmse_warn, "NRMSE above: WARN")
    nrmse_error: float = parameter(_THRESHOLDS.nrmse_error, "NRMSE above: ERROR")
    summary_file: str = parameter("", "run summary JSON at shutdown; empty: none")

    @property
    def thresholds(self) -> Thresholds:
        """The level thresholds these settings hold."""
        return Thresholds(**{name: getattr(self, name) for name in _THRESHOLD_NAMES})


_THRESHOLD_NAMES = tuple(item.name for item in fields(Thresholds))


@dataclass(frozen=True)
class RecorderSettings:
    """Parameters of the ``recorder`` node (``config/recorder.yaml``).

    ``flush_interval_s`` bounds what ``kill -9`` loses (the open chunk is committed once it
    is that old, or at ``chunk_bytes``); ``qos_depth`` of 30 000 is 30 s at 1 kHz (a recorder
    starved for seconds catches up); Fast DDS holds more than 5000 only under a profile that
    raises its resource limits, as the project's loopback profile does.
    """

    output_dir: str = parameter(
        "",
        "the recording directory is made here; empty: the working directory, or "
        "~/brake_hil_recordings when that is inside the brake_hil source checkout",
    )
    bag_name: str = parameter("", "the recording directory's name; empty: brake_hil_<UTC time>")
    topics: tuple[str, ...] = parameter(
        ("/brake/**", "/diagnostics"), "topic globs to record: * one name level, ** any depth"
    )
    max_file_bytes: int = parameter(0, "split files at this size; 0: no limit", "bytes")
    max_file_duration_s: float = parameter(
        0.0, "split files after this much log time; 0: no limit", "s"
    )
    chunk_bytes: int = parameter(
        1 << 20, "MCAP chunk (uncompressed), the unit that reaches the disk", "bytes"
    )
    flush_interval_s: float = parameter(
        0.1, "commit the open chunk once it is this old: what kill -9 loses at most", "s"
    )
    metadata_interval_s: float = parameter(
        1.0, "rewrite metadata.yaml at most this often while recording; 0: every chunk", "s"
    )
    discovery_interval_s: float = parameter(
        0.2, "search the ROS graph for new topics this often", "s"
    )
    take_interval_s: float = parameter(
        0.01, "take what the middleware holds for every topic this often", "s"
    )
    qos_depth: int = parameter(30_000, "history of the reliable subscriptions", "samples")


@dataclass(frozen=True)
class RigEmulatorSettings:
    """Parameters of the ``rig_emulator`` node (``config/rig_emulator.yaml``).

    The run is a :class:`~brake_hil.physics.excitation.PulsingSchedule` (:attr:`schedule`)
    through ``simulator`` (``virtual_rig`` with ``effects``, or ``lti``, the seed's model).
    """

    rig_file: str = parameter("", "truth rig YAML; empty: config/rig_default.yaml")
    simulator: str = parameter("virtual_rig", "virtual_rig (effects) or lti (the paper's model)")
    effects: tuple[str, ...] = parameter(
        ("",), 'virtual-rig effects, e.g. ["seal_stick_slip=0.5"]; [""]: none'
    )
    max_pressures: tuple[float, ...] = parameter(
        DEFAULT_SCHEDULE.max_pressures, "pulsing maxima, one ramp-then-pulse segment each", "Pa"
    )
    ramp_s: float = parameter(DEFAULT_SCHEDULE.ramp_s, "ramp to each maximum", "s")
    pulsing_s: float = parameter(DEFAULT_SCHEDULE.pulsing_s, "pulsing per maximum", "s")
    pulsing_hz: float = parameter(DEFAULT_SCHEDULE.pulsing_hz, "pulsing frequency", "Hz")
    seed: int = parameter(0, "sensor-noise seed")
    loop: bool = parameter(True, "replay the run forever (counter and stamps run on); false: exit")
    output: str = parameter("topics", "topics, can or both")
    can_interface: str = parameter(
        "slcan_pty", "slcan_pty (pseudo-terminal slcan adapter) or a python-can interface"
    )
    can_channel: str = parameter("", "python-can channel (not for slcan_pty)")
    can_bitrate: int = parameter(1_000_000, "CAN bitrate", "bit/s")
    can_link_path: str = parameter(
        "", "symlink to the pty; empty: rig_can in a private temp folder (logged)"
    )
    can_hold_s: float = parameter(
        1.0, "slcan_pty: hold a frame this long while its reader lags, then drop it; 0: drop", "s"
    )
    dbc_file: str = parameter("", "CAN database; empty: config/brake_rig.dbc")
    frame_id: str = parameter("caliper", "header.frame_id")
    wait_for_subscribers: int = parameter(
        0, "start once every sample topic has this many (and an slcan pty its reader)"
    )
    wait_timeout_s: float = parameter(30.0, "start anyway after this wait", "s")
    start_delay_s: float = parameter(1.0, "then wait this long before the first sample", "s")
    diagnostics_period_s: float = parameter(1.0, "diagnostics period", "s")

    @property
    def schedule(self) -> PulsingSchedule:
        """The excitation these settings describe."""
        return PulsingSchedule(
            self.max_pressures,
            ramp_s=self.ramp_s,
            pulsing_s=self.pulsing_s,
            pulsing_hz=self.pulsing_hz,
        )


NODE_SETTINGS: dict[str, type[DataclassInstance]] = {
    "pressure_source": PressureSourceSettings,
    "caliper_model": CaliperModelSettings,
    "comparator": ComparatorSettings,
    "recorder": RecorderSettings,
    "rig_emulator": RigEmulatorSettings,
}
"""Each node's settings dataclass, by node (and console script) name."""

_PARAMS_FILES = {"recorder": "recorder.yaml", "rig_emulator": "rig_emulator.yaml"}


def _type_name(kind: Any) -> str:
    if typing.get_origin(kind) is tuple:
        return f"{typing.get_args(kind)[0].__name__}[]"
    return str(kind.__name__)


_ROLE = re.compile(r":[a-z]+:`(~?)([^`]+)`")
"""A Sphinx cross-reference, ``:role:`target``` (``~``: its last name shown)."""


def _plain(text: str) -> str:
    """``text`` as plain help text: cross-references as the names they show, no backticks."""

    def shown(match: re.Match[str]) -> str:
        tilde, target = match.groups()
        return target.rsplit(".", 1)[-1] if tilde else target

    return _ROLE.sub(shown, text).replace("``", "").replace("`", "")


def help_text(node: str) -> str:
    """The ``--help`` of a node: usage, what it does, every parameter.

    Each parameter with its type, default, unit and description, from the node's settings
    dataclass (:data:`NODE_SETTINGS`), so the help and the node cannot disagree.

    Args:
        node: the node's name, a key of :data:`NODE_SETTINGS`.
    """
    settings = NODE_SETTINGS[node]
    params_file = _PARAMS_FILES.get(node, "nodes.yaml")
    doc = _plain(settings.__doc__ or "").strip().splitlines()
    body = "\n".join(line.strip() for line in doc[1:]).strip()
    lines = [
        f"usage: {node} [-h] [--ros-args -p NAME:=VALUE ... | --ros-args --params-file FILE]",
        f"       ros2 run brake_hil {node} --ros-args -p NAME:=VALUE",
        "",
        f"The brake_hil {node} node (params file: config/{params_file}).",
    ]
    if body:
        lines += ["", body]
    lines += ["", "parameters (name  type  default  [unit]  description):"]
    for spec in parameter_specs(settings):
        default = list(spec.default) if isinstance(spec.default, tuple) else spec.default
        unit = f"  [{spec.unit}]" if spec.unit else ""
        lines.append(f"  {spec.name}  {_type_name(spec.kind)}  {default!r}{unit}")
        lines.append(f"      {spec.description}")
    lines += ["", "-h, --help  print this and exit (starts nothing, writes nothing)"]
    return "\n".join(lines)
