"""What a node's process does before ROS starts: its help, its environment, its folders.

ROS-free, so that ``NODE --help`` answers without importing rclpy: each node's entry module
(``brake_hil.nodes.<name>``) runs :func:`run_entry`, which imports the node only to run it.

* :func:`answer_help` prints a node's usage and parameters for ``-h``/``--help``.
* :func:`setup_environment` keeps DDS discovery on loopback unless the caller chose otherwise.
* :func:`recording_directory`, :func:`config_path`: where the recorder writes by default,
  where a ``config/`` file is.
* :func:`write_summary`: a node's closing figures as JSON.
"""

from __future__ import annotations

from collections.abc import Sequence
import importlib
import json
import os
from pathlib import Path
import sys

from brake_hil.nodes.settings import NODE_SETTINGS, help_text
from brake_hil.runtime import loopback_environment

__all__ = [
    "CHECKOUT",
    "HELP_FLAGS",
    "RECORDINGS_HOME",
    "answer_help",
    "asks_for_help",
    "config_path",
    "is_source_checkout",
    "recording_directory",
    "run_entry",
    "setup_environment",
    "write_summary",
]


def setup_environment() -> None:
    """DDS on loopback only, unless ``ROS_AUTOMATIC_DISCOVERY_RANGE`` says otherwise.

    Local-only (``LOCALHOST``, the default) with no Fast DDS profile of the user's: the
    project's loopback profile, under ``SYSTEM_DEFAULT`` so that it alone is in force
    (:func:`brake_hil.runtime.loopback_environment`).
    """
    loopback_environment(os.environ)


HELP_FLAGS = ("-h", "--help")
"""What asks a node for its help (before ``--ros-args``)."""
CHECKOUT = Path(__file__).resolve().parents[2]
"""The folder above the package: the source checkout when run from one."""
RECORDINGS_HOME = "~/brake_hil_recordings"
"""Where the recorder writes by default when started inside the source checkout."""


def asks_for_help(args: Sequence[str] | None) -> bool:
    """True when the command line (``sys.argv`` when None) holds ``-h``/``--help``.

    Only the node's own arguments count: those before ``--ros-args``.
    """
    argv = list(sys.argv[1:] if args is None else args)
    if "--ros-args" in argv:
        argv = argv[: argv.index("--ros-args")]
    return any(flag in argv for flag in HELP_FLAGS)


def is_source_checkout(folder: Path) -> bool:
    """True when ``folder`` is the brake_hil source checkout this package runs from, or in it."""
    if not (CHECKOUT / "package.xml").is_file() or not (CHECKOUT / "brake_hil").is_dir():
        return False
    folder = folder.resolve()
    return folder == CHECKOUT or CHECKOUT in folder.parents


def recording_directory(output_dir: str, cwd: Path | None = None) -> Path:
    """Where the recorder makes its recording directory.

    ``output_dir`` when given; else the working directory (as ``ros2 bag record`` does),
    unless that is the source checkout or inside it: then :data:`RECORDINGS_HOME`, so no
    node writes into the source tree by default.
    """
    if output_dir:
        return Path(output_dir).expanduser()
    here = Path.cwd() if cwd is None else cwd
    if is_source_checkout(here):
        return Path(RECORDINGS_HOME).expanduser()
    return here


def config_path(name: str) -> Path:
    """A file of ``config/`` in the checkout, else in the install's ``share/brake_hil``."""
    checkout = Path(__file__).resolve().parents[2] / "config" / name
    if checkout.is_file():
        return checkout
    return Path(sys.prefix) / "share" / "brake_hil" / "config" / name


def write_summary(path: str, summary: object) -> None:
    """Write a node's closing figures as JSON to ``path`` (nothing when it is empty)."""
    if not path:
        return
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")


def answer_help(name: str, args: Sequence[str] | None) -> bool:
    """Print the usage of node ``name`` when its command line asks for help; True if so.

    The usage and every parameter (:func:`~brake_hil.nodes.settings.help_text`); nothing is
    started, advertised or written.
    """
    if not asks_for_help(args):
        return False
    print(help_text(name) if name in NODE_SETTINGS else f"usage: {name} [--ros-args ...]")
    return True


def run_entry(name: str, args: Sequence[str] | None) -> int:
    """The process of node ``name``: its help, or its ROS side run; the exit status.

    The ROS side, ``brake_hil.nodes.<name>_node``, and so rclpy, is imported only to run.
    """
    if answer_help(name, args):
        return 0
    node = importlib.import_module(f"brake_hil.nodes.{name}_node")
    return int(node.main(args))
