"""A node started with params files gets their values, declared from its settings dataclass
(a real ``pressure_source`` process, asked over its parameter services), and the package-file
defaults resolve as before."""

from __future__ import annotations

import json
from pathlib import Path
import signal
import subprocess
import sys
import time
from typing import Any

from rcl_interfaces.srv import DescribeParameters, GetParameters
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter, parameter_value_to_python
import yaml

from brake_hil.nodes import common
from brake_hil.nodes.settings import CaliperModelSettings, PressureSourceSettings, parameter_specs
from test.conftest import CONFIG, PROJECT
from test.nodes.harness import Collector, ros_domain, unique_domain_id


def call(node: Node, service_type: Any, name: str, request: Any, timeout_s: float = 20.0) -> Any:
    """One service call from ``node`` (spun by its Collector's executor)."""
    client: Any = node.create_client(service_type, name)
    assert client.wait_for_service(timeout_sec=timeout_s), f"no service {name}"
    future = client.call_async(request)
    deadline = time.monotonic() + timeout_s
    while not future.done() and time.monotonic() < deadline:
        time.sleep(0.02)
    assert future.done(), f"{name} did not answer"
    return future.result()


def test_pressure_source_gets_the_values_of_its_params_files(tmp_path: Path) -> None:
    overrides = {
        "mode": "can",  # no recording needed: python-can's virtual bus
        "can_channel": f"brake_hil_params_{tmp_path.name}",
        "stale_after_ms": 7.5,
        "frame_id": "left_caliper",
        "diagnostics_period": 0.5,
        "statistics_file": str(tmp_path / "statistics.json"),
        "rate": 2.0,
        "loop": True,
        "wait_for_topics": ["/brake/model/bore/pressure:2", "/x"],
        "spin_margin_us": 80,
    }
    override_file = tmp_path / "overrides.yaml"
    override_file.write_text(yaml.safe_dump({"pressure_source": {"ros__parameters": overrides}}))
    expected = yaml.safe_load((CONFIG / "nodes.yaml").read_text())["pressure_source"]
    expected = {**expected["ros__parameters"], **overrides}
    specs = parameter_specs(PressureSourceSettings)
    names = [spec.name for spec in specs]
    assert sorted(expected) == sorted(names)

    with ros_domain(unique_domain_id()) as env:
        log = (tmp_path / "pressure_source.log").open("wb")
        process = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "brake_hil.nodes.pressure_source",
                "--ros-args",
                "--params-file",
                str(CONFIG / "nodes.yaml"),  # dbc_file: config/brake_rig.dbc, from PROJECT
                "--params-file",
                str(override_file),
            ],
            cwd=PROJECT,
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
        collector = Collector([])
        try:
            values = call(
                collector.node,
                GetParameters,
                "/pressure_source/get_parameters",
                GetParameters.Request(names=names),
            ).values
            descriptors = call(
                collector.node,
                DescribeParameters,
                "/pressure_source/describe_parameters",
                DescribeParameters.Request(names=names),
            ).descriptors
        finally:
            collector.close()
            process.send_signal(signal.SIGINT)
            code = process.wait(20)
            log.close()
    output = (tmp_path / "pressure_source.log").read_text()
    assert code == 0, output
    got = {name: parameter_value_to_python(value) for name, value in zip(names, values)}
    for spec in specs:
        value = spec.convert(got[spec.name])
        assert value == spec.convert(expected[spec.name]), spec.name
    for spec, descriptor in zip(specs, descriptors):
        assert descriptor.name == spec.name
        assert descriptor.description == spec.text
        assert descriptor.read_only
    statistics = json.loads((tmp_path / "statistics.json").read_text())
    assert statistics["mode"] == "can"
    assert "daq" in statistics


def test_package_file_defaults_name_the_package_config_and_overrides_win() -> None:
    context = Context()
    rclpy.init(context=context)
    try:
        plain = Node("caliper_model", context=context)
        settings = common.declare_settings(plain, CaliperModelSettings)
        assert settings.model_file == str(common.config_path("rig_default.yaml"))
        assert Path(settings.model_file).is_absolute()
        assert settings == CaliperModelSettings(model_file=settings.model_file)
        overrides: list[Parameter[Any]] = [
            Parameter("mean_pressure", value=1.2e6),
            Parameter("hold_mode", value="hold"),
        ]
        node = Node("caliper_model", context=context, parameter_overrides=overrides)
        settings = common.declare_settings(node, CaliperModelSettings)
        assert (settings.mean_pressure, settings.hold_mode) == (1.2e6, "hold")
        descriptor = node.describe_parameter("loop_period")
        assert descriptor.description == "tick period (s)" and descriptor.read_only
        plain.destroy_node()
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
