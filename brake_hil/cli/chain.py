"""The command line of the node-chain launcher: ``python -m brake_hil.nodes.chain``.

Parses the options, runs ``brake_hil.app.chain.run_chain`` (``--layout``: which nodes share
a process, ``brake_hil.nodes.container``; ``--one-process`` the four in one; or
``run_can_chain`` with ``--can-emulator``), prints its notices as
they come and then the comparator's run summary, the model's timing and where the MCAP is.
Closing lines: the run judged (``ChainResult.verdict``): samples predicted and recorded, steady
cycles scored against those the recording holds, real time, the model loop's timing (OK, WARN,
ERROR). Exit status: 0 when every judgement holds; 1 when one fails or a node exited with an
error (one line on stderr per cause); 2 on bad input (one line on stderr). ``--help``
imports neither the runs nor rclpy.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
import math
from pathlib import Path
import sys
from typing import TYPE_CHECKING

from brake_hil.app.chain_environment import DEFAULT_MODEL, DEFAULT_RECORDING, PROJECT
from brake_hil.app.chain_layouts import DEFAULT_LAYOUT, LAYOUTS
from brake_hil.app.chain_processes import CONTAINER
from brake_hil.errors import BrakeHilError
from brake_hil.topics import OUTPUT_CHANNELS

if TYPE_CHECKING:
    from brake_hil.app.chain_result import ChainResult

__all__ = ["add_layout_arguments", "build_parser", "main", "result_lines"]

DESCRIPTION = (
    "The node chain as separate processes (or fewer, --layout): source -> caliper model -> "
    "comparator -> recorder."
)


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Each option's default after its help, unless the help says it or there is none.

    None, a flag's False and an empty list are no default worth saying.
    """

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if action.default in (None, False, []) or "default" in text:
            return text
        return super()._get_help_string(action)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the launcher."""
    parser = argparse.ArgumentParser(
        prog="python -m brake_hil.nodes.chain",
        description=DESCRIPTION,
        formatter_class=HelpFormatter,
    )
    parser.add_argument(
        "recording",
        type=Path,
        nargs="?",
        default=DEFAULT_RECORDING,
        help="recording to replay (rosbag2 directory or .mcap)",
    )
    parser.add_argument(
        "--model",
        type=Path,
        default=DEFAULT_MODEL,
        help="model file (rig YAML or improved_model.json)",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=PROJECT / "out" / "chain",
        help="folder for the recording, the nodes' logs and summaries "
        "(with --can-emulator: out/chain_can)",
    )
    parser.add_argument("--rate", type=float, default=1.0, help="replay rate factor")
    parser.add_argument(
        "--domain-id",
        type=int,
        default=None,
        help="ROS_DOMAIN_ID of the nodes (default: a free one picked per run)",
    )
    parser.add_argument("--no-recorder", action="store_true", help="run without the recorder")
    parser.add_argument(
        "--realtime-priority",
        type=int,
        default=0,
        help="SCHED_FIFO priority of the source's and the model's loop threads (0: none)",
    )
    add_layout_arguments(parser, default=None)
    parser.add_argument(
        "--can-emulator",
        action="store_true",
        help="instead of replaying RECORDING, run against the rig emulator over CAN (slcan pty)",
    )
    parser.add_argument(
        "--effect",
        action="append",
        default=[],
        help="with --can-emulator: a virtual-rig effect, NAME[=STRENGTH]",
    )
    return parser


def add_layout_arguments(
    parser: argparse.ArgumentParser, default: str | None = DEFAULT_LAYOUT
) -> None:
    """``--layout`` (which nodes share a process) and ``--one-process``, into ``args.layout``.

    ``default`` None: the caller picks (the chain: :data:`DEFAULT_LAYOUT` for a replay).
    """
    said = (
        f"default {DEFAULT_LAYOUT} for a replay, processes with --can-emulator"
        if default is None
        else f"default {default}"
    )
    parser.add_argument(
        "--layout",
        choices=tuple(LAYOUTS),
        default=default,
        help=(
            f"which nodes share a process ({said}): one-paired (the four in one process, the "
            "model stepped on the source's thread, one subscription per topic), processes "
            "(each its own), two-process (source and model in one, comparator and recorder in "
            "another), paired (as two-process, the model stepped on the source's thread after "
            "each sample), model-apart (source, comparator and recorder in one process, the "
            "caliper model in its own), one-process (the four in python -m "
            "brake_hil.nodes.container: the model's loop on its own thread shares the GIL: "
            "period error and latency of milliseconds at p99)"
        ),
    )
    parser.add_argument(
        "--one-process",
        action="store_const",
        const="one-process",
        dest="layout",
        help="the same as --layout one-process",
    )


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m brake_hil.nodes.chain``; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.layout is None:
        args.layout = "processes" if args.can_emulator else DEFAULT_LAYOUT
    if args.layout != "processes" and args.can_emulator:
        parser.error("--layout runs a replay; it does not combine with --can-emulator")
    from brake_hil.app.chain_runs import run_can_chain, run_chain

    try:
        if args.can_emulator:
            out = (
                args.out
                if args.out != PROJECT / "out" / "chain"
                else PROJECT / "out" / "chain_can"
            )
            result = run_can_chain(
                args.model, args.effect, args.model, out, domain_id=args.domain_id, progress=print
            )
        else:
            result = run_chain(
                args.recording,
                args.model,
                args.out,
                args.rate,
                args.domain_id,
                progress=print,
                recorder=not args.no_recorder,
                realtime_priority=args.realtime_priority,
                layout=args.layout,
            )
    except BrakeHilError as err:
        print(f"chain: error: {err}", file=sys.stderr)
        return 2
    for line in result_lines(result):
        print(line)
    status, held, failed = result.verdict()
    for line in held:
        print(f"chain: {line}")
    for line in failed:
        print(f"chain: {line}", file=sys.stderr)
    return status


def result_lines(result: ChainResult) -> list[str]:
    """What the launcher prints after a run: comparison, model timing, CPU, the MCAP."""
    lines: list[str] = []
    comparator = result.comparator
    if comparator is None:
        lines.append("no comparator summary")
    else:
        window = comparator["window_cycles"]
        lines.append(
            f"comparison (comparator: means over steady cycles, window of {window} cycles)"
        )
        lines.append(
            f"{'channel':8s}{'ptp ratio %':>13s}{'tau/T %':>10s}{'NRMSE':>9s}{'cycles':>8s}  level"
        )
        for channel, entry in comparator["metrics"].items():
            if entry.get("cycles"):
                lines.append(
                    f"{channel:8s}{entry['ptp_ratio_pct']:13.1f}{entry['tau_over_T_pct']:10.2f}"
                    f"{entry['nrmse']:9.4f}{entry['cycles']:8d}  {entry['level']}"
                )
            else:
                lines.append(f"{channel:8s}  no steady cycle scored")
    model = result.model
    if model is not None:
        counters = model["counters"]
        period, latency = model["period_error"], model["latency"]
        lines.append(
            f"caliper_model: {counters['samples']} samples in, {counters['predictions']} "
            f"predictions out; period error median {_us(period, 'median')}, p99 "
            f"{_us(period, 'p99')}, max {_us(period, 'max')}; latency median "
            f"{_us(latency, 'median')}, p99 {_us(latency, 'p99')}, max {_us(latency, 'max')}; "
            f"{counters['overruns']} overruns"
        )
    if result.cpu_s:
        per = "of the one process" if list(result.cpu_s) == [CONTAINER] else "per process"
        lines.append(
            f"CPU time (s) {per}: "
            + ", ".join(f"{name} {seconds:.1f}" for name, seconds in result.cpu_s.items())
        )
    if result.bag is not None:
        lines.append(f"MCAP recording: {result.bag}")
        check = result.check
        if check is not None:
            counts = (
                f"recorded {int(check['inputs'])} inputs, {int(check['predictions'])} predictions"
            )
            if "max_dev_p_b" in check:
                deviations = ", ".join(f"{c} {check[f'max_dev_{c}']:.1e}" for c in OUTPUT_CHANNELS)
                lines.append(
                    f"{counts}; largest deviation from the batch model (of ptp): {deviations}"
                )
            else:
                lines.append(
                    f"{counts}: the recording misses samples, no comparison with the batch"
                )
    elif "recorder" in result.missing:
        lines.append("no MCAP: the recorder node is not available")
    return lines


def _us(summary: dict[str, float], name: str) -> str:
    """One quantile of a timing summary's JSON (``median``, ``p99``, ``max``) for people."""
    from brake_hil.runtime.timing import format_us

    return format_us(summary[f"{name}_us"], summary.get("ceiling_us", math.inf))
