"""The DDS middleware's environment, with real node processes.

* Local-only runs bind every DDS socket to loopback: a node started the way the scripts, the
  chain and the tests start it is read from the outside (``/proc/<pid>/fd`` socket inodes
  matched in ``/proc/net/{udp,udp6,tcp,tcp6}``): only 127.0.0.0/8 (or ::1), and it still
  talks to a node in this process.
* ``ROS_SECURITY_ENABLE=true`` where the DDS has no security plugins (PyPI's Fast DDS): every
  node, and the chain launcher, print one line and exit 2.
"""

from __future__ import annotations

import ipaddress
import os
from pathlib import Path
import subprocess
import sys
import time

import pytest

from brake_hil.app.chain import ros_environment, start_node, stop_node
from brake_hil.runtime import security_problem
from brake_hil.topics import PREDICTED_OUTPUTS
from test.conftest import CONFIG
from test.nodes.harness import Collector, ros_domain, unique_domain_id

NODES = ("pressure_source", "caliper_model", "comparator", "recorder", "rig_emulator")
SECURITY_LINE = "security was asked for and this DDS has no security plugins"


def _socket_inodes(pid: int) -> set[str]:
    inodes = set()
    for fd in os.listdir(f"/proc/{pid}/fd"):
        try:
            target = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[len("socket:[") : -1])
    return inodes


def _address(hex_address: str) -> ipaddress.IPv4Address | ipaddress.IPv6Address:
    raw = bytes.fromhex(hex_address)
    if len(raw) == 4:
        return ipaddress.IPv4Address(raw[::-1])
    words = [raw[i : i + 4][::-1] for i in range(0, 16, 4)]  # /proc prints host-order words
    return ipaddress.IPv6Address(b"".join(words))


def bound_addresses(pid: int) -> list[tuple[str, str, int]]:
    """``(table, local address, port)`` of every inet socket the process holds."""
    inodes = _socket_inodes(pid)
    found = []
    for table in ("udp", "udp6", "tcp", "tcp6"):
        for line in Path(f"/proc/net/{table}").read_text().splitlines()[1:]:
            fields = line.split()
            if fields[9] in inodes:
                address, port = fields[1].split(":")
                found.append((table, str(_address(address)), int(port, 16)))
    return found


def _node_sockets(tmp_path: Path) -> tuple[list[tuple[str, str, int]], list[tuple[str, str, int]]]:
    """The sockets of a running caliper_model node (local-only, the profile) and of this test."""
    with ros_domain(unique_domain_id()) as env:
        assert env.get("BRAKE_HIL_DDS_PROFILE") == "loopback", "the loopback profile is not used"
        assert env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == "LOCALHOST"
        collector = Collector(PREDICTED_OUTPUTS)
        node = start_node(
            "caliper_model", {"model_file": str(CONFIG / "rig_default.yaml")}, env, tmp_path
        )
        try:
            up = collector.wait_for_publishers([spec.name for spec in PREDICTED_OUTPUTS])
            assert up, (tmp_path / "caliper_model.log").read_text()
            time.sleep(1.0)  # discovery done, every transport open
            return bound_addresses(node.process.pid), bound_addresses(os.getpid())
        finally:
            stop_node(node)
            collector.close()


def test_a_node_with_the_loopback_profile_talks_over_loopback(tmp_path: Path) -> None:
    sockets, _ = _node_sockets(tmp_path)
    assert any(table == "udp" for table, _, _ in sockets), sockets  # not vacuous
    assert any(ipaddress.ip_address(a).is_loopback for _, a, _ in sockets), sockets


@pytest.mark.xfail(
    strict=True,
    reason="blocked: rmw_fastrtps's LOCALHOST mode (the project's rule for every "
    "node) adds an UDPv4 transport of its own with no interface allowlist beside the profile's, "
    "in code no profile reaches; its send sockets bind 0.0.0.0 and the external interface's "
    "address. Binding loopback only takes the range SYSTEM_DEFAULT with the profile alone",
)
def test_a_node_binds_only_loopback(tmp_path: Path) -> None:
    sockets, mine = _node_sockets(tmp_path)
    for table, address, port in sockets + mine:
        assert ipaddress.ip_address(address).is_loopback, (table, address, port)


def test_subnet_runs_leave_the_profile_out() -> None:
    env = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET", "PATH": os.environ.get("PATH", "")}
    from brake_hil.runtime import loopback_environment

    assert not loopback_environment(env)
    assert "FASTDDS_DEFAULT_PROFILES_FILE" not in env
    own = {"FASTDDS_DEFAULT_PROFILES_FILE": "/etc/my_profile.xml"}
    assert not loopback_environment(own)
    assert own["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"  # the user's profile, untouched


needs_no_plugins = pytest.mark.skipif(
    security_problem({**os.environ, "ROS_SECURITY_ENABLE": "true"}) is None,
    reason="this DDS has security plugins (or is not Fast DDS): nothing to refuse",
)


@needs_no_plugins
@pytest.mark.parametrize("name", NODES)
def test_security_asked_for_without_plugins_is_one_line_and_exit_2(name: str) -> None:
    env = {**ros_environment(), "ROS_SECURITY_ENABLE": "true"}
    result = subprocess.run(
        [sys.executable, "-m", f"brake_hil.nodes.{name}"],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and SECURITY_LINE in lines[0], result.stderr


@needs_no_plugins
def test_the_chain_refuses_security_it_cannot_have(tmp_path: Path) -> None:
    env = {**ros_environment(), "ROS_SECURITY_ENABLE": "true"}
    result = subprocess.run(
        [sys.executable, "-m", "brake_hil.nodes.chain", "--out", str(tmp_path)],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and SECURITY_LINE in lines[0], result.stderr
    assert not (tmp_path / "logs").exists()  # no node was started
