"""The nodes' settings dataclasses against the params files in ``config/`` (no ROS needed):
every node's section lists exactly its dataclass's parameters, in order, with the dataclass's
defaults and types."""

from __future__ import annotations

import subprocess
import sys
import typing
from typing import Any

import pytest
import yaml

from brake_hil.nodes.settings import (
    CaliperModelSettings,
    ComparatorSettings,
    ParameterSpec,
    PressureSourceSettings,
    RecorderSettings,
    RigEmulatorSettings,
    parameter_specs,
)
from test.conftest import CONFIG

SECTIONS: list[tuple[str, str, type[Any]]] = [
    ("nodes.yaml", "pressure_source", PressureSourceSettings),
    ("nodes.yaml", "caliper_model", CaliperModelSettings),
    ("nodes.yaml", "comparator", ComparatorSettings),
    ("recorder.yaml", "recorder", RecorderSettings),
    ("rig_emulator.yaml", "rig_emulator", RigEmulatorSettings),
]
"""(params file, node, settings dataclass)."""


def section(file_name: str, node: str) -> dict[str, Any]:
    document = yaml.safe_load((CONFIG / file_name).read_text(encoding="utf-8"))
    parameters: dict[str, Any] = document[node]["ros__parameters"]
    return parameters


def has_type(value: object, kind: Any) -> bool:
    """True when a YAML value is what ROS declares for ``kind`` (no int for a float)."""
    if typing.get_origin(kind) is tuple:
        (item, _) = typing.get_args(kind)
        return isinstance(value, list) and all(has_type(v, item) for v in value)
    return type(value) is kind


@pytest.mark.parametrize(("file_name", "node", "settings"), SECTIONS, ids=lambda v: str(v))
def test_params_file_lists_every_parameter_with_its_default(
    file_name: str, node: str, settings: type[Any]
) -> None:
    listed = section(file_name, node)
    specs = parameter_specs(settings)
    assert list(listed) == [spec.name for spec in specs]
    for spec in specs:
        value = listed[spec.name]
        assert has_type(value, spec.kind), f"{node}.{spec.name}: {value!r} is not {spec.kind}"
        assert spec.convert(value) == spec.default, f"{node}.{spec.name}"
        assert has_type(
            list(spec.default) if isinstance(spec.default, tuple) else spec.default, spec.kind
        )


@pytest.mark.parametrize("settings", sorted({s for _, _, s in SECTIONS}, key=str))
def test_every_parameter_is_described_and_package_files_exist(settings: type[Any]) -> None:
    for spec in parameter_specs(settings):
        assert spec.description, f"{settings.__name__}.{spec.name}"
        if spec.package_file:
            assert spec.default.startswith("config/")
            assert (CONFIG / spec.package_file_name).is_file()
    assert settings() == settings(**{s.name: s.default for s in parameter_specs(settings)})


def test_array_values_become_tuples_of_the_field_type() -> None:
    spec = {s.name: s for s in parameter_specs(RigEmulatorSettings)}["max_pressures"]
    assert spec.convert([1.0e6, 2]) == (1.0e6, 2.0)
    assert isinstance(spec.convert([1.0e6, 2])[1], float)
    assert ParameterSpec("x", float, 1.0, "a length", "m", False).text == "a length (m)"


def test_settings_and_schedule_agree() -> None:
    settings = RigEmulatorSettings(max_pressures=(2.0e6,), ramp_s=0.5, pulsing_s=2.0)
    schedule = settings.schedule
    assert (schedule.max_pressures, schedule.ramp_s, schedule.pulsing_s) == ((2.0e6,), 0.5, 2.0)
    assert schedule.pulsing_hz == settings.pulsing_hz
    assert ComparatorSettings(nrmse_warn=0.2).thresholds.nrmse_warn == 0.2


def test_settings_import_without_rclpy() -> None:
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('rclpy', 'rosidl_runtime_py', 'rcl_interfaces'):\n"
        "            raise ImportError('rclpy blocked for this test: ' + name)\n"
        "sys.meta_path.insert(0, Block())\n"
        "import brake_hil.nodes.settings\n"
        "assert not any(m.startswith('rclpy') for m in sys.modules)\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
