"""The chain's environment: where its defaults are, the nodes' DDS environment, its checks.

Every node of a run gets the same environment: DDS on loopback (unless the user set a Fast DDS
profile of their own), one ``ROS_DOMAIN_ID`` for the run. DDS security asked for where the
middleware has no security plugins is refused before any node starts. No rclpy.
"""

from __future__ import annotations

from collections.abc import Mapping
import importlib.util
import os
from pathlib import Path
import time

from brake_hil.errors import DdsSecurityError
from brake_hil.runtime import loopback_environment, security_problem

__all__ = [
    "DEFAULT_MODEL",
    "DEFAULT_RECORDING",
    "PROJECT",
    "check_security",
    "choose_domain_id",
    "node_available",
    "ros_environment",
]

PROJECT = Path(__file__).resolve().parents[2]
DEFAULT_RECORDING = PROJECT / "bags" / "one_washer_lti"
DEFAULT_MODEL = PROJECT / "config" / "rig_default.yaml"


def ros_environment(domain_id: int | None = None) -> dict[str, str]:
    """The environment of a node process: DDS on loopback, the run's domain.

    Local-only: the project's loopback profile with ``SYSTEM_DEFAULT`` (every socket on
    127.0.0.1), or ``LOCALHOST`` where the profile is not loaded (a Fast DDS profile of the
    user's own, ``BRAKE_HIL_DDS_PROFILE=off``, another middleware):
    :func:`brake_hil.runtime.loopback_environment`.
    """
    env = dict(os.environ)
    inherited = env.get("BRAKE_HIL_DDS_PROFILE") == "loopback"  # profile + SYSTEM_DEFAULT
    if not (inherited and env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == "SYSTEM_DEFAULT"):
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    loopback_environment(env)
    env["ROS_DOMAIN_ID"] = str(choose_domain_id() if domain_id is None else domain_id)
    env["PYTHONUNBUFFERED"] = "1"
    return env


def check_security(env: Mapping[str, str]) -> None:
    """Refuse DDS security the middleware cannot give (:class:`DdsSecurityError`)."""
    problem = security_problem(dict(env))
    if problem is not None:
        raise DdsSecurityError(problem)


def choose_domain_id() -> int:
    """A domain id (1-100) unlikely to be shared with another run on this host."""
    return 1 + (os.getpid() * 7919 + time.time_ns() // 1_000_000) % 100


def node_available(name: str) -> bool:
    """True when ``brake_hil.nodes.<name>`` exists."""
    return importlib.util.find_spec(f"brake_hil.nodes.{name}") is not None
