"""The DDS middleware's environment, with real node processes.

* Local-only runs bind every DDS socket to loopback: each node, and every process of a chain
  run, started the way the scripts, the chain and the tests start them, is read from the
  outside (``/proc/<pid>/fd`` socket inodes matched in ``/proc/net/{udp,udp6,tcp,tcp6}``): only
  127.0.0.0/8 (or ::1), and a node still talks to a node in this process. The shell that runs
  these tests exports ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``: the start paths switch it to
  ``SYSTEM_DEFAULT`` only together with the loopback profile.
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
from brake_hil.runtime import loopback_profile_path, security_problem
from brake_hil.topics import PREDICTED_OUTPUTS
from test.conftest import CONFIG, PROJECT
from test.nodes.harness import Collector, ros_domain, unique_domain_id

BAG = PROJECT / "bags" / "one_washer_lti"
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


def _assert_local_only_with_profile(env: dict[str, str]) -> None:
    assert env.get("BRAKE_HIL_DDS_PROFILE") == "loopback", "the loopback profile is not used"
    assert env.get("FASTDDS_DEFAULT_PROFILES_FILE") == str(loopback_profile_path())
    assert env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == "SYSTEM_DEFAULT"


def _node_sockets(tmp_path: Path) -> tuple[list[tuple[str, str, int]], list[tuple[str, str, int]]]:
    """The sockets of a running caliper_model node (local-only, the profile) and of this test."""
    with ros_domain(unique_domain_id()) as env:
        _assert_local_only_with_profile(env)
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


def _not_loopback(sockets: list[tuple[str, str, int]]) -> list[tuple[str, str, int]]:
    return [s for s in sockets if not ipaddress.ip_address(s[1]).is_loopback]


def test_a_node_with_the_loopback_profile_talks_over_loopback(tmp_path: Path) -> None:
    sockets, _ = _node_sockets(tmp_path)
    assert any(table == "udp" for table, _, _ in sockets), sockets  # not vacuous
    assert any(ipaddress.ip_address(a).is_loopback for _, a, _ in sockets), sockets


def test_a_node_binds_only_loopback(tmp_path: Path) -> None:
    sockets, mine = _node_sockets(tmp_path)
    assert _not_loopback(sockets + mine) == [], sockets + mine


NODE_PARAMETERS: dict[str, dict[str, object]] = {
    "pressure_source": {"recording": str(BAG), "loop": True},
    "caliper_model": {"model_file": str(CONFIG / "rig_default.yaml")},
    "comparator": {},
    "recorder": {"bag_name": "bag"},
    "rig_emulator": {},
}


@pytest.mark.parametrize("name", NODES)
def test_every_node_binds_only_loopback(name: str, tmp_path: Path) -> None:
    parameters = dict(NODE_PARAMETERS[name])
    if name == "recorder":
        parameters["output_dir"] = str(tmp_path / "recorded")
    with ros_domain(unique_domain_id()) as env:
        _assert_local_only_with_profile(env)
        node = start_node(name, parameters, env, tmp_path)
        try:
            deadline = time.monotonic() + 60.0
            sockets: list[tuple[str, str, int]] = []
            while time.monotonic() < deadline and node.process.poll() is None:
                sockets = bound_addresses(node.process.pid)
                if sum(table == "udp" for table, _, _ in sockets) >= 3:
                    break  # discovery's sockets are open; give the rest a moment
                time.sleep(0.2)
            time.sleep(1.5)
            assert node.process.poll() is None, (tmp_path / f"{name}.log").read_text()
            sockets = bound_addresses(node.process.pid)
        finally:
            stop_node(node)
    assert sum(table == "udp" for table, _, _ in sockets) >= 3, sockets  # not vacuous
    assert _not_loopback(sockets) == [], sockets


def _descendants(pid: int) -> set[int]:
    found: set[int] = set()
    todo = [pid]
    while todo:
        parent = todo.pop()
        try:
            tasks = os.listdir(f"/proc/{parent}/task")
        except OSError:
            continue
        for task in tasks:
            try:
                children = Path(f"/proc/{parent}/task/{task}/children").read_text().split()
            except OSError:
                continue
            for child in map(int, children):
                if child not in found:
                    found.add(child)
                    todo.append(child)
    return found


@pytest.mark.parametrize(("layout", "node_processes"), [("one-paired", 1), ("processes", 4)])
def test_every_process_of_a_chain_binds_only_loopback(
    tmp_path: Path, layout: str, node_processes: int
) -> None:
    """The default layout (one process for the four nodes) and one process per node."""
    env = ros_environment()
    _assert_local_only_with_profile(env)
    command = [sys.executable, "-m", "brake_hil.nodes.chain", str(BAG), "--out", str(tmp_path)]
    command += ["--layout", layout]
    chain = subprocess.Popen(
        command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    seen: dict[int, list[tuple[str, str, int]]] = {}
    try:
        deadline = time.monotonic() + 120.0
        while chain.poll() is None and time.monotonic() < deadline:
            for pid in _descendants(chain.pid) | {chain.pid}:
                try:
                    seen.setdefault(pid, []).extend(bound_addresses(pid))
                except OSError:
                    pass  # exited meanwhile
            time.sleep(0.5)
        output, _ = chain.communicate(timeout=120)
    finally:
        if chain.poll() is None:
            chain.terminate()
            chain.wait(30)
    with_dds = {pid: s for pid, s in seen.items() if any(t == "udp" for t, _, _ in s)}
    assert len(with_dds) >= node_processes, (seen, output)  # the layout's nodes: not vacuous
    bad = {pid: _not_loopback(s) for pid, s in with_dds.items() if _not_loopback(s)}
    assert bad == {}, output


def test_local_only_means_the_profile_and_system_default() -> None:
    from brake_hil.runtime import loopback_environment

    env = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}  # as the test shell exports it
    assert loopback_environment(env)
    _assert_local_only_with_profile(env)
    child = dict(env)
    assert loopback_environment(child) and child == env  # a child inherits it unchanged
    unset: dict[str, str] = {}
    assert loopback_environment(unset) and unset == env  # local-only is the default


def test_subnet_runs_leave_the_profile_out() -> None:
    env = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET", "PATH": os.environ.get("PATH", "")}
    from brake_hil.runtime import loopback_environment

    assert not loopback_environment(env)
    assert "FASTDDS_DEFAULT_PROFILES_FILE" not in env
    inherited = {**_profiled(), "ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}
    assert not loopback_environment(inherited)  # SUBNET asked for under an inherited profile
    assert inherited == {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}


def _profiled() -> dict[str, str]:
    from brake_hil.runtime import loopback_environment

    env = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    assert loopback_environment(env)
    return env


@pytest.mark.parametrize(
    "change",
    [
        {"FASTDDS_DEFAULT_PROFILES_FILE": "/etc/my_profile.xml"},
        {"BRAKE_HIL_DDS_PROFILE": "off"},
        {"RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"},
    ],
    ids=["own-profile", "off", "other-rmw"],
)
def test_without_the_profile_the_range_stays_localhost(change: dict[str, str]) -> None:
    from brake_hil.runtime import loopback_environment

    own = change.get("FASTDDS_DEFAULT_PROFILES_FILE")
    fresh = dict(change)
    assert not loopback_environment(fresh)
    assert fresh["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert fresh.get("FASTDDS_DEFAULT_PROFILES_FILE") == own
    inherited = {**_profiled(), **change}  # set in a shell that had the profile
    assert not loopback_environment(inherited)
    assert inherited["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"  # never SYSTEM_DEFAULT alone
    assert inherited.get("FASTDDS_DEFAULT_PROFILES_FILE") == own
    assert inherited.get("BRAKE_HIL_DDS_PROFILE") == change.get("BRAKE_HIL_DDS_PROFILE")


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
