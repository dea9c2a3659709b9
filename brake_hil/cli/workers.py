"""Where a command's work over many recordings runs: ``--jobs``, ``--scheduler``, ``--serial``.

:func:`add_workers_arguments` adds the three (one at most) to a sub-command;
:func:`workers_from_args` turns them into a :class:`~brake_hil.app.parallel.Workers` for
:func:`~brake_hil.app.parallel.parallel_map`. With none given, a running scheduler named by
``$DASK_SCHEDULER_ADDRESS`` is used, else a Dask ``LocalCluster`` of one worker per core.
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping
import os

from brake_hil.app.parallel import Workers

__all__ = ["SCHEDULER_VARIABLE", "add_workers_arguments", "workers_from_args"]

SCHEDULER_VARIABLE = "DASK_SCHEDULER_ADDRESS"
"""The environment variable that names a running Dask scheduler (``--scheduler``'s default)."""


def add_workers_arguments(parser: argparse.ArgumentParser) -> None:
    """``--jobs N``, ``--scheduler ADDRESS`` and ``--serial`` (mutually exclusive)."""
    group = parser.add_argument_group(
        "workers", "where the recordings are worked on (Dask); at most one of these"
    )
    choice = group.add_mutually_exclusive_group()
    choice.add_argument(
        "--jobs",
        type=int,
        metavar="N",
        help="worker processes of a Dask LocalCluster started on this computer, on loopback "
        "(default: one per core)",
    )
    choice.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (default: "
        f"${SCHEDULER_VARIABLE}; without it, --jobs' default)",
    )
    choice.add_argument(
        "--serial", action="store_true", help="in this process, one recording after the other"
    )


def workers_from_args(
    args: argparse.Namespace, environ: Mapping[str, str] | None = None
) -> Workers:
    """The :class:`~brake_hil.app.parallel.Workers` of parsed ``--jobs/--scheduler/--serial``.

    Args:
        args: parsed by a parser given :func:`add_workers_arguments`.
        environ: where ``$DASK_SCHEDULER_ADDRESS`` is read (default ``os.environ``); used
            only when none of the three options is given.

    Raises:
        BrakeHilError: ``--jobs`` below 1.
    """
    if args.serial:
        return Workers(serial=True)
    if args.jobs is not None:
        return Workers(jobs=args.jobs)
    if args.scheduler:
        return Workers(scheduler=args.scheduler)
    scheduler = (os.environ if environ is None else environ).get(SCHEDULER_VARIABLE, "").strip()
    return Workers(scheduler=scheduler or None)
