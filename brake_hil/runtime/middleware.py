"""The DDS middleware's environment, for every path that starts a ROS node (ROS-free).

* :func:`loopback_environment`: local-only runs keep every DDS socket on loopback. When
  ``ROS_AUTOMATIC_DISCOVERY_RANGE`` is ``LOCALHOST`` (the default: local only), the middleware
  is Fast DDS and the user has set no Fast DDS profile of their own, it points
  ``FASTDDS_DEFAULT_PROFILES_FILE`` at ``config/fastdds_loopback.xml`` (a shared-memory
  transport and one UDPv4 transport allowed on 127.0.0.1 only, builtin transports off,
  discovery by unicast to 127.0.0.1, no multicast) and sets the range to ``SYSTEM_DEFAULT``:
  rmw_fastrtps's ``LOCALHOST`` mode adds an UDPv4 transport of its own with no interface
  allowlist beside the profile's (its send sockets bind the wildcard and each interface's
  address), in code no profile reaches; under ``SYSTEM_DEFAULT`` the profile alone is in force
  and every socket is on 127.0.0.1. ``BRAKE_HIL_DDS_PROFILE=loopback`` records that the range
  was switched because the profile is loaded, so a child process inherits a consistent
  environment and treats it as local-only. Without the profile (``BRAKE_HIL_DDS_PROFILE=off``,
  a profile of one's own, another middleware) the range stays ``LOCALHOST``: never
  ``SYSTEM_DEFAULT`` without the profile. ``SUBNET`` leaves the profile out.
* :func:`security_problem`: ``ROS_SECURITY_ENABLE=true`` with a Fast DDS built without its
  security plugins (PyPI's) is one line and exit 2 in every node, rather than a traceback or
  a silently insecure run.
"""

from __future__ import annotations

from collections.abc import Iterator, MutableMapping
import mmap
import os
from pathlib import Path
import sys

__all__ = [
    "LOOPBACK_PROFILE",
    "loopback_environment",
    "loopback_profile_path",
    "security_problem",
]

LOOPBACK_PROFILE = "fastdds_loopback.xml"
"""The Fast DDS profile of local-only runs, in ``config/``."""
_PROFILE_VARIABLES = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")
_SECURITY_MARK = b"builtin.PKI-DH"  # the authentication plugin's name, in a build that has it


def loopback_profile_path() -> Path:
    """``config/fastdds_loopback.xml`` of the checkout, else of the install's share folder."""
    checkout = Path(__file__).resolve().parents[2] / "config" / LOOPBACK_PROFILE
    if checkout.is_file():
        return checkout
    return Path(sys.prefix) / "share" / "brake_hil" / "config" / LOOPBACK_PROFILE


def _uses_fast_dds(env: MutableMapping[str, str]) -> bool:
    return env.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp").startswith("rmw_fastrtps")


def _drop_profile(env: MutableMapping[str, str], profile: Path) -> None:
    """Undo an inherited loopback profile no longer in force: never SYSTEM_DEFAULT without it."""
    ours = env.get("BRAKE_HIL_DDS_PROFILE") == "loopback"
    if ours:
        del env["BRAKE_HIL_DDS_PROFILE"]
    for name in _PROFILE_VARIABLES:
        if env.get(name) and Path(env[name]) == profile:
            del env[name]
            ours = True
    if ours and env.get("ROS_AUTOMATIC_DISCOVERY_RANGE") == "SYSTEM_DEFAULT":
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"


def loopback_environment(env: MutableMapping[str, str]) -> bool:
    """Make ``env`` (``os.environ`` or a child's) local-only on loopback; True: profile in force.

    ``ROS_AUTOMATIC_DISCOVERY_RANGE`` defaults to ``LOCALHOST``; see the module docstring for
    what is set then. Idempotent: a child of a process it ran in inherits the result
    (``BRAKE_HIL_DDS_PROFILE=loopback`` with ``SYSTEM_DEFAULT`` and the profile).
    """
    discovery = env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    profile = loopback_profile_path()
    marked = env.get("BRAKE_HIL_DDS_PROFILE", "") == "loopback"
    local = discovery == "LOCALHOST" or (marked and discovery == "SYSTEM_DEFAULT")
    off = env.get("BRAKE_HIL_DDS_PROFILE", "") == "off"
    own = [env[name] for name in _PROFILE_VARIABLES if env.get(name)]
    if (
        not local
        or off
        or any(Path(path) != profile for path in own)  # the user's own profile
        or not _uses_fast_dds(env)
        or not profile.is_file()
    ):
        if marked or off:
            _drop_profile(env, profile)
        return False
    env["FASTDDS_DEFAULT_PROFILES_FILE"] = str(profile)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SYSTEM_DEFAULT"  # the profile alone: loopback only
    env["BRAKE_HIL_DDS_PROFILE"] = "loopback"
    return True


def _library_folders(env: MutableMapping[str, str]) -> Iterator[Path]:
    yield Path(sys.prefix) / "lib"
    for variable in ("AMENT_PREFIX_PATH", "COLCON_PREFIX_PATH"):
        for prefix in env.get(variable, "").split(os.pathsep):
            if prefix:
                yield Path(prefix) / "lib"
    for folder in env.get("LD_LIBRARY_PATH", "").split(os.pathsep):
        if folder:
            yield Path(folder)
    yield from sorted(Path("/opt/ros").glob("*/lib"))
    yield from (Path("/usr/lib/x86_64-linux-gnu"), Path("/usr/lib/aarch64-linux-gnu"))


def _fast_dds_library(env: MutableMapping[str, str]) -> Path | None:
    for folder in _library_folders(env):
        for name in ("libfastdds.so", "libfastrtps.so"):
            candidate = folder / name
            if candidate.exists():
                return candidate.resolve()
    return None


def _has_security_plugins(library: Path) -> bool:
    with library.open("rb") as stream:
        with mmap.mmap(stream.fileno(), 0, access=mmap.ACCESS_READ) as data:
            return data.find(_SECURITY_MARK) >= 0


def security_problem(env: MutableMapping[str, str] | None = None) -> str | None:
    """Why the asked-for DDS security cannot be had here; None when it can (or is not asked).

    Only a Fast DDS found and known to be built without its security plugins is a problem;
    another middleware, or none found, is left to rcl.
    """
    env = os.environ if env is None else env
    if env.get("ROS_SECURITY_ENABLE", "").strip().lower() != "true" or not _uses_fast_dds(env):
        return None
    library = _fast_dds_library(env)
    if library is None:
        return None
    try:
        if _has_security_plugins(library):
            return None
    except (OSError, ValueError):
        return None
    return (
        "security was asked for and this DDS has no security plugins (ROS_SECURITY_ENABLE=true; "
        f"{library} is built without them): run with SROS2 on a ROS 2 distro (README, "
        "'ROS 2 networking'), or unset ROS_SECURITY_ENABLE"
    )
