"""The virtual rig imports with rclpy made unimportable (style.md: a ROS-free core)."""

from __future__ import annotations

import subprocess
import sys

MODULES = [
    "brake_hil.virtual_rig",
    "brake_hil.virtual_rig.effects",
    "brake_hil.virtual_rig.simulator",
    "brake_hil.virtual_rig.cases",
    "brake_hil.virtual_rig.bag",
    "brake_hil.virtual_rig.cli",
]


def test_virtual_rig_imports_without_rclpy() -> None:
    code = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('rclpy', 'rosidl_runtime_py', 'rcl_interfaces'):\n"
        "            raise ImportError('rclpy blocked for this test: ' + name)\n"
        "sys.meta_path.insert(0, Block())\n"
        + "".join(f"import {module}\n" for module in MODULES)
        + "assert not any(m.startswith('rclpy') for m in sys.modules)\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
