"""``brake-hil compare`` and ``brake-hil characterize``: one recording against its rig file."""

from __future__ import annotations

import argparse
from pathlib import Path
import sys
from typing import TYPE_CHECKING

from brake_hil.cli.verb import RECORDING_HELP, Verb, add_database_argument, json_written

if TYPE_CHECKING:
    from brake_hil.analysis.segment_comparison import RecordingComparison
    from brake_hil.analysis.sweep_characterization import SweepCharacterization

RIG_HELP = "the rig file (YAML; default: RECORDING.rig.yaml beside the recording)"


def _rig(args: argparse.Namespace) -> Path:
    """``--rig``, else the rig file beside the recording, said on stderr (as ``diagnose`` does).

    Raises:
        RecordingError: no such recording.
        BrakeHilError: no rig file beside it (the message says to pass ``--rig``).
    """
    from brake_hil.io.recording_paths import existing_recording, rig_beside

    existing_recording(args.recording)
    if args.rig is not None:
        return Path(args.rig)
    rig = rig_beside(args.recording)
    print(f"rig file: {rig} (beside the recording; --rig to choose another)", file=sys.stderr)
    return rig


__all__ = ["CharacterizeVerb", "CompareVerb", "print_segments", "print_sweep"]


def print_sweep(sweep: SweepCharacterization) -> None:
    """Table 3 against frequency: one row per band, each value with its standard error."""
    s = sweep.segment
    d = s.descriptors
    print(
        f"sweep {s.t_start:.2f}-{s.t_end:.2f} s, {float(d['f0_hz']):.1f} -> "
        f"{float(d['f1_hz']):.1f} Hz ({d['law']}): the seal per band (+- one standard error)"
    )
    print(f"{'f Hz':>6s}{'k_eh MN/m':>18s}{'c_eh kN s/m':>18s}{'k_eh*':>15s}{'eta_eh':>15s}")
    for b in sweep.bands:
        print(
            f"{b.frequency_hz:6.1f}{b.k_eh / 1e6:10.3f} +-{b.k_eh_sigma / 1e6:6.3f}"
            f"{b.c_eh / 1e3:10.1f} +-{b.c_eh_sigma / 1e3:6.1f}"
            f"{b.k_eh_star:8.3f} +-{b.k_eh_star_sigma:5.3f}"
            f"{b.eta_eh:8.3f} +-{b.eta_eh_sigma:5.3f}"
        )


def print_segments(comparison: RecordingComparison) -> None:
    """One line per segment (times, kind, what it is), then its metric per channel."""
    from brake_hil.cli.segment_lines import segment_lines

    for line in segment_lines(comparison):
        print(line)


class CompareVerb(Verb):
    """The paper's Table 4-5 metrics per channel."""

    name = "compare"
    help = "run the rig's LTI model on a recording: Tables 4-5 metrics (ptp ratio, tau/T, NRMSE)"

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``RECORDING [--rig RIG] [--json F] [--plot F] [--db URL]``."""
        parser.add_argument("recording", type=Path, help=RECORDING_HELP)
        parser.add_argument("--rig", type=Path, help=RIG_HELP)
        parser.add_argument("--json", type=Path, help="also write the metrics here as JSON")
        parser.add_argument("--plot", type=Path, help="PNG of measured vs predicted")
        add_database_argument(parser, "default: none")

    def main(self, args: argparse.Namespace) -> int:
        """The metrics table; the plot, JSON and database row when asked for."""
        from brake_hil.app.compare import run_compare
        from brake_hil.app.output import removed_if_refused
        from brake_hil.app.results_db import check_database, database_folder

        rig = _rig(args)
        with removed_if_refused(database_folder(args.db)):
            result = run_compare(
                args.recording, rig, args.json, args.plot, lambda: check_database(args.db)
            )
        print(f"recording {args.recording}  rig {rig} ({result.rig.name})")
        print_segments(result.comparison)
        metrics = result.comparison.metrics()
        print(f"over {result.comparison.basis.replace('_', ' ')}:")
        counted = "cycles" if result.comparison.pulsing is not None else "samples"
        print(f"{'channel':8s}{'ptp ratio %':>13s}{'tau/T %':>10s}{'NRMSE':>9s}{counted:>8s}")
        for channel, m in metrics.items():
            print(
                f"{channel:8s}{m['ptp_ratio_pct']:13.1f}{m['tau_over_T_pct']:10.2f}"
                f"{m['nrmse']:9.4f}{int(m[counted]):8d}"
            )
        for figure in result.figures:
            print(f"plot written to {figure}")
        json_written(result.json_path)
        if args.db:
            from brake_hil.app.results_db import append_comparison

            stored = append_comparison(args.recording, rig, metrics, args.db)
            print(f"results appended to {stored}")
        return 0


class CharacterizeVerb(Verb):
    """The paper's Table 3 per steady segment."""

    name = "characterize"
    help = (
        "the seal's stiffness and damping per segment and per sweep band "
        "(Table 3 of Liette, Dreyer, Singh 2012)"
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """``RECORDING [--rig RIG] [--json F]``."""
        parser.add_argument("recording", type=Path, help=RECORDING_HELP)
        parser.add_argument("--rig", type=Path, help=RIG_HELP)
        parser.add_argument("--json", type=Path, help="also write the table here as JSON")

    def main(self, args: argparse.Namespace) -> int:
        """One row per steady segment, one per band of each sweep; the JSON when asked for."""
        from brake_hil.app.characterize import run_characterize

        rig = _rig(args)
        result = run_characterize(args.recording, rig, args.json)
        header = (
            f"{'segment s':>13s}{'max p MPa':>10s}{'k_eh*':>7s}{'eta_eh':>7s}"
            f"{'2c_fs*':>7s}{'2c_ss*':>7s}{'2c_fb*':>7s}{'xi':>6s}  slips"
        )
        print(f"recording {args.recording}  rig {rig} ({result.rig.name})")
        print(f"segments found ({len(result.found)}):")
        for found in result.found:
            print(f"  {found.t_start:6.2f}-{found.t_end:6.2f} s  {found.kind}")
        if result.segments:
            print("steady pulsing (Table 3):")
            print(header)
        for s in result.segments:
            print(
                f"{s.t_start:6.2f}-{s.t_end:6.2f}{s.max_pressure / 1e6:10.2f}{s.k_eh_star:7.3f}"
                f"{s.eta_eh:7.3f}{s.two_c_fs_star:7.3f}{s.two_c_ss_star:7.3f}"
                f"{s.two_c_fb_star:7.3f}{s.xi:6.2f}  {'yes' if s.seal_slips else 'no'}"
            )
        for sweep in result.sweeps:
            print_sweep(sweep)
        json_written(result.json_path)
        return 0
