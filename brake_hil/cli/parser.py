"""The argument parser of ``brake-hil``: every sub-command, its options and their help.

It imports nothing heavy (no numpy, scipy, virtual rig), so ``brake-hil --help`` is quick:
the few values its help shows from the simulator (:data:`EXCITATIONS`,
:data:`SOLVER_METHOD`, :data:`RELATIVE_TOLERANCE`) are repeated here and
``test/cli/test_cli_help.py`` keeps them in step.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from brake_hil import __version__
from brake_hil.errors import BrakeHilError
from brake_hil.physics.catalogue import CATALOGUE

__all__ = [
    "EXCITATIONS",
    "RELATIVE_TOLERANCE",
    "SOLVER_METHOD",
    "build_parser",
    "uses_virtual_rig",
]

EXCITATIONS = ("pulsing", "solenoid", "ramp", "sweep")
"""``brake_hil.app.simulate.EXCITATIONS``."""
SOLVER_METHOD = "BDF"
"""``brake_hil.virtual_rig.simulator.SOLVER_METHOD``."""
RELATIVE_TOLERANCE = 1.0e-4
"""``brake_hil.virtual_rig.simulator.RELATIVE_TOLERANCE``."""
_RECORDING_HELP = "rosbag2 directory (MCAP or sqlite3) or a bare .mcap file"

_VIRTUAL_OPTIONS = ("effect", "excitation", "nominal", "rig_out", "method", "rtol")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``brake-hil``."""
    from brake_hil.cli.workers import add_workers_arguments

    parser = argparse.ArgumentParser(
        prog="brake-hil", description="Hardware-in-the-loop tools for hydraulic disk brakes."
    )
    parser.add_argument("--version", action="version", version=f"brake-hil {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    cmp = commands.add_parser("compare", help="run the rig's LTI model on a recording")
    cmp.add_argument("recording", type=Path, help=_RECORDING_HELP)
    cmp.add_argument("--rig", type=Path, required=True, help="the rig file (YAML) to model")
    cmp.add_argument("--json", type=Path, help="also write the metrics here as JSON")
    cmp.add_argument("--plot", type=Path, help="PNG of measured vs predicted")
    add_database_argument(cmp, "default: none")
    chz = commands.add_parser("characterize", help="the seed's Table 3 from a recording")
    chz.add_argument("recording", type=Path, help=_RECORDING_HELP)
    chz.add_argument("--rig", type=Path, required=True, help="the rig file (YAML)")
    chz.add_argument("--json", type=Path, help="also write the table here as JSON")
    _add_diagnose_parser(commands)
    sim = commands.add_parser(
        "simulate", help="write a recording of the LTI model or of the virtual rig"
    )
    sim.add_argument("--rig", type=Path, required=True, help="the rig to simulate (truth)")
    sim.add_argument("--out", type=Path, required=True, help="new rosbag2 directory")
    sim.add_argument(
        "--max-pressure",
        type=float,
        nargs="+",
        default=[1.38e6],
        help="maximum master-cylinder pressures, Pa (one segment each)",
    )
    sim.add_argument(
        "--pulsing-seconds", type=float, default=5.0, help="5 Hz pulsing per segment, s (5)"
    )
    sim.add_argument("--seed", type=int, default=0, help="sensor-noise seed (0)")
    _add_virtual_rig_arguments(sim)
    _add_cases_parser(commands)
    bench = commands.add_parser("benchmark", help="score the diagnosis blind on labelled cases")
    bench.add_argument("directory", type=Path, help="made by 'brake-hil cases'")
    add_workers_arguments(bench)
    bench.add_argument("--json", type=Path, help="also write the figures here as JSON")
    reg = commands.add_parser("regress", help="replay recordings through the model vs a baseline")
    reg.add_argument(
        "recordings",
        type=Path,
        nargs="+",
        help="recordings to replay; one without steady 5 Hz pulsing is skipped with a note",
    )
    reg.add_argument("--baseline", type=Path, required=True, help="baseline JSON")
    reg.add_argument("--model", type=Path, help="model file (default: the baseline's)")
    reg.add_argument("--update", action="store_true", help="rewrite the baseline")
    add_database_argument(reg, "default: none")
    add_workers_arguments(reg)
    _add_recover_parser(commands)
    _add_fleet_parser(commands)
    _add_trend_parser(commands)
    return parser


def add_database_argument(parser: argparse.ArgumentParser, default: str) -> None:
    """``--db``: the results database a command appends to."""
    parser.add_argument(
        "--db",
        metavar="URL",
        help="results database to append to: an SQLite file, sqlite:///PATH, or a PostgreSQL "
        f"server's postgresql://USER@HOST:PORT/DBNAME (libpq's URL; {default})",
    )


def _add_diagnose_parser(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """``brake-hil diagnose RECORDING... [--rig] [--out] [--db]`` and the workers' options."""
    from brake_hil.cli.workers import add_workers_arguments

    dgn = commands.add_parser(
        "diagnose",
        help="find and model the physics the model left out",
        description="Diagnose one recording, or many: folders of recordings and globs "
        "(quoted, e.g. 'lab/**/run-*') are diagnosed on Dask, each into its own folder under "
        "--out, and every result is appended to the results database.",
    )
    dgn.add_argument(
        "recording",
        type=Path,
        nargs="+",
        help=_RECORDING_HELP + "; or folders of recordings, or globs (many recordings)",
    )
    dgn.add_argument(
        "--rig",
        type=Path,
        help="the nominal rig file (YAML; default: RECORDING.rig.yaml beside each recording)",
    )
    dgn.add_argument(
        "--out",
        type=Path,
        help="folder for diagnosis.json, improved_model.json and report.html (default: "
        "out/<recording name>/ in the working directory); many recordings: the folder that "
        "gets one folder per recording (default: out/)",
    )
    add_database_argument(dgn, "default: results.sqlite in the output folder")
    add_workers_arguments(dgn)


def _add_fleet_parser(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """``brake-hil fleet --out DIR``: the virtual lab of ``trend``'s example."""
    from brake_hil.cli.workers import add_workers_arguments

    fleet = commands.add_parser(
        "fleet",
        help="write a small virtual lab's daily recordings (one rig wearing, one steady)",
        description="Two virtual rigs recorded once a day: rig-1's seals wear and air collects "
        "in its fluid, rig-2 stays steady. Diagnose them with 'brake-hil diagnose DIR', then "
        "'brake-hil trend'. What was simulated is in DIR/truth.json, which neither reads.",
    )
    fleet.add_argument("--out", type=Path, required=True, help="new directory")
    fleet.add_argument("--runs", type=int, default=30, help="recordings per rig, one a day (30)")
    fleet.add_argument("--seed", type=int, default=0, help="draws the rigs and the noise (0)")
    fleet.add_argument(
        "--pulsing-seconds", type=float, default=5.0, help="per pressure segment (5: 18 s)"
    )
    add_workers_arguments(fleet)


def _add_trend_parser(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """``brake-hil trend --db F [--rig NAME] [--out DIR]``."""
    trend = commands.add_parser(
        "trend",
        help="each rig's calibrated values and effects across its stored diagnoses",
        description="Read the diagnoses of the results database in time order and say, per "
        "rig, which calibrated value drifted or sits off the rig file and which effect grew "
        "(only trends beyond doubt); write trend.html with a figure per rig.",
    )
    trend.add_argument(
        "--db",
        required=True,
        metavar="URL",
        help="the results database: an SQLite file, sqlite:///PATH, or "
        "postgresql://USER@HOST:PORT/DBNAME",
    )
    trend.add_argument("--rig", metavar="NAME", help="only this rig (its name in the rig file)")
    trend.add_argument(
        "--out",
        type=Path,
        help="folder for trend.html and its figures (default: trend/ beside the database "
        "file; for PostgreSQL, trend/ here)",
    )


def _add_recover_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """``brake-hil recover BAG [--out DIR]``."""
    rec = commands.add_parser(
        "recover",
        help="write a finished copy of an unfinished MCAP recording (kill -9, full disk)",
        description="Read every whole chunk of a recording a writer did not finish (no "
        "summary, a cut file, metadata.yaml missing or stale) and write them into a new "
        "rosbag2 directory with summaries, indexes, statistics and a matching metadata.yaml. "
        "The input is never written to.",
    )
    rec.add_argument("bag", type=Path, help="rosbag2 directory of .mcap files, or a .mcap file")
    rec.add_argument(
        "--out", type=Path, help="new rosbag2 directory (default: BAG_recovered beside BAG)"
    )


def _add_virtual_rig_arguments(parser: argparse.ArgumentParser) -> None:
    """The virtual-rig options of ``brake-hil simulate``."""
    group = parser.add_argument_group(
        "virtual rig", "any of these (or --engine virtual) simulates the virtual rig"
    )
    group.add_argument(
        "--engine",
        choices=("lti", "virtual"),
        help="lti: the seed's LTI model (the default without virtual-rig options); "
        "virtual: the higher-fidelity rig",
    )
    group.add_argument(
        "--effect",
        action="append",
        metavar="NAME[=STRENGTH][,PARAM=VALUE...]",
        help=f"add an effect (repeatable): {', '.join(CATALOGUE)}; strength 0-1 (default 1)",
    )
    group.add_argument(
        "--excitation",
        choices=EXCITATIONS,
        help="pulsing: p_i ramp then 5 Hz (default); solenoid: air pressure through the "
        "master cylinder (eqs. 21a-b); ramp: rise, hold, fall to the highest pressure; "
        "sweep: 5-25 Hz over --pulsing-seconds x 2",
    )
    group.add_argument(
        "--nominal", type=Path, help="the rig the engineer believes (YAML; default: --rig)"
    )
    group.add_argument(
        "--rig-out", type=Path, help="write the nominal rig YAML here (default OUT.rig.yaml)"
    )
    group.add_argument(
        "--method", choices=("BDF", "Radau", "LSODA"), help=f"stiff solver ({SOLVER_METHOD})"
    )
    group.add_argument("--rtol", type=float, help=f"solver tolerance ({RELATIVE_TOLERANCE:g})")


def _add_cases_parser(commands: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """The ``brake-hil cases`` sub-command."""
    from brake_hil.cli.workers import add_workers_arguments

    cases = commands.add_parser(
        "cases", help="write labelled virtual-rig cases for scoring a diagnosis blind"
    )
    cases.add_argument("--out", type=Path, required=True, help="new directory")
    cases.add_argument("--count", type=int, default=26, help="number of cases (26: one round)")
    cases.add_argument("--seed", type=int, default=0, help="draws the cases (0)")
    cases.add_argument(
        "--pulsing-seconds", type=float, default=5.0, help="per pressure segment (5: 18 s)"
    )
    add_workers_arguments(cases)
    cases.add_argument(
        "--error-scale", type=float, default=1.0, help="scales the rig tolerances (1 sigma)"
    )
    cases.add_argument(
        "--kind",
        action="append",
        choices=("null", "single", "pair", "unexplained"),
        default=[],
        help="keep only cases of this kind (repeatable; default: every kind)",
    )
    cases.add_argument(
        "--family",
        choices=("a", "b"),
        default="a",
        help="family of truth laws: a (the registered laws, default) or b (a second, "
        "structurally different law per effect and its own measurement chain)",
    )
    cases.add_argument(
        "--excitation-hz",
        type=float,
        default=None,
        help="pulsing frequency of every case (default: the nominal rig's, 5 Hz)",
    )
    cases.add_argument(
        "--max-pressures",
        type=_megapascals,
        default=None,
        metavar="MPA,MPA,...",
        help="one steady segment per maximum pressure (default: the seed's 1.38,2.07,2.76)",
    )


def uses_virtual_rig(args: argparse.Namespace) -> bool:
    """True when ``simulate`` should run the virtual rig.

    Raises:
        BrakeHilError: a virtual-rig option with ``--engine lti``.
    """
    given = [name for name in _VIRTUAL_OPTIONS if getattr(args, name, None) is not None]
    if args.engine == "lti" and given:
        options = ", ".join("--" + name.replace("_", "-") for name in given)
        raise BrakeHilError(f"{options} need the virtual rig; drop --engine lti")
    return args.engine == "virtual" or bool(given)


def _megapascals(text: str) -> tuple[float, ...]:
    """``--max-pressures``: comma-separated MPa, in Pa."""
    try:
        return tuple(float(part) * 1e6 for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: give comma-separated pressures in MPa, e.g. 1.0,1.8,2.5"
        ) from None
