"""The chain's environment: where its defaults are, the nodes' DDS environment, its checks.

Every node of a run gets the same environment: DDS on loopback (unless the user set a Fast DDS
profile of their own), one ``ROS_DOMAIN_ID`` for the run. DDS security asked for where the
middleware has no security plugins is refused before any node starts. No rclpy.
"""

from __future__ import annotations

from collections.abc import Mapping
import fcntl
import importlib.util
import os
from pathlib import Path
import tempfile
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


DOMAIN_LOCKS = Path(tempfile.gettempdir())
"""Where a process holds ``brake_hil_ros_domain_N.lock`` for each domain id it uses."""
_held_domains: dict[int, int] = {}  # domain id -> the open, locked file's descriptor


def choose_domain_id() -> int:
    """A domain id (1-100) no other process on this host holds, held while this one lives.

    Each id is a lock file (``DOMAIN_LOCKS``), taken with ``flock`` and kept open (not
    inherited by the node processes: closed and released when this process ends). Starts at a
    place drawn from the process id and the clock; when every id is held (or no lock can be
    made), the drawn one (shared then, as before any lock).
    """
    start = (os.getpid() * 7919 + time.time_ns() // 1_000_000) % 100
    for step in range(100):
        domain = 1 + (start + step) % 100
        if domain in _held_domains:
            continue
        try:
            fd = os.open(
                DOMAIN_LOCKS / f"brake_hil_ros_domain_{domain}.lock", os.O_RDWR | os.O_CREAT
            )
        except OSError:
            continue  # another user's lock file: theirs
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            continue
        _held_domains[domain] = fd
        return domain
    return 1 + start


def node_available(name: str) -> bool:
    """True when ``brake_hil.nodes.<name>`` exists."""
    return importlib.util.find_spec(f"brake_hil.nodes.{name}") is not None
