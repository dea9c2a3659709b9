"""The core, the I/O layer, the diagnosis and the virtual rig import with rclpy made
unimportable (style.md)."""

from __future__ import annotations

import subprocess
import sys

CORE_MODULES = [
    "brake_hil.core.rig",
    "brake_hil.core.parameters",
    "brake_hil.core.lti_model",
    "brake_hil.core.signals",
    "brake_hil.core.characterization",
    "brake_hil.core.comparison",
    "brake_hil.io.recording_reader",
    "brake_hil.io.recording_writer",
    "brake_hil.io.mcap_recorder",
    "brake_hil.io.can_daq",
    "brake_hil.core.diagnosis.diagnose",
    "brake_hil.core.diagnosis.improved_model",
    "brake_hil.virtual_rig",
    "brake_hil.virtual_rig.effects",
    "brake_hil.virtual_rig.simulator",
    "brake_hil.virtual_rig.cases",
    "brake_hil.virtual_rig.bag",
    "brake_hil.virtual_rig.cli",
    "brake_hil.scoring",
    "brake_hil.cli",
]


def test_core_imports_without_rclpy() -> None:
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('rclpy', 'rosidl_runtime_py', 'rcl_interfaces'):\n"
        "            raise ImportError('rclpy blocked for this test: ' + name)\n"
        "sys.meta_path.insert(0, Block())\n"
        + "".join(f"import {module}\n" for module in CORE_MODULES)
        + "assert not any(m.startswith('rclpy') for m in sys.modules)\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
