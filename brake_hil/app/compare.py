"""``brake-hil compare``: the rig file's LTI model against a recording, segment by segment.

Steady pulsing is scored with the seed's Tables 4-5 (unchanged); sweeps, ramps, steps, holds
and modulated trains with the metric that fits each (:mod:`brake_hil.analysis.segment_comparison`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from brake_hil.analysis.segment_comparison import RecordingComparison, compare_segments
from brake_hil.app.naming import naming
from brake_hil.app.output import check_outputs, removed_if_refused, write_json
from brake_hil.io.opened import open_recording
from brake_hil.physics.rig import Rig

__all__ = ["CompareResult", "run_compare"]


@dataclass(frozen=True)
class CompareResult:
    """The comparison and the files it was written to."""

    recording_path: Path
    rig_path: Path
    rig: Rig
    comparison: RecordingComparison
    document: dict[str, object]  # what the JSON file holds
    json_path: Path | None
    plot_path: Path | None
    figures: tuple[Path, ...] = ()  # every figure written (the first is plot_path)


def run_compare(
    recording_path: Path,
    rig_path: Path | None = None,
    json_path: Path | None = None,
    plot_path: Path | None = None,
    ready: Callable[[], None] | None = None,
) -> CompareResult:
    """Run the rig's LTI model on the recording's ``p_i`` and score it on each segment.

    Args:
        recording_path: a recording with ``p_i`` and the three measured outputs.
        rig_path: the rig YAML (default: ``RECORDING.rig.yaml`` beside the recording).
        json_path: write the comparison here as JSON (``None``: nowhere).
        plot_path: write a PNG of measured against predicted here (``None``: no plot); a
            sweep's Bode plot and a ramp's static map go beside it (``NAME.sweep.png``,
            ``NAME.ramp.png``), and the segments over time too when there is steady pulsing
            (``NAME.segments.png``).
        ready: called once the inputs are opened and the outputs checked, before the work
            (the command checks its database there).

    The inputs are opened and checked before any output folder is made; a refusal after
    that removes the folders it made (nothing is left of a refused command).

    Returns:
        The comparison.

    Raises:
        BrakeHilError: no such recording, a bad rig file or recording, or nothing but idle
            (the message names the file).
    """
    opened = open_recording(recording_path, rig_path)  # the inputs first: a refusal writes nothing
    recording, rig, rig_path = opened.recording, opened.rig, opened.rig_path
    parents = [path.parent for path in (json_path, plot_path) if path is not None]
    with removed_if_refused(*parents):
        check_outputs(json_path, plot_path)
        if ready is not None:
            ready()
        with naming(recording_path):
            comparison = compare_segments(recording, rig)
            document = {
                "recording": str(recording_path),
                "rig": str(rig_path),
                **comparison.as_dict(),
            }
        figures: tuple[Path, ...] = ()
        if plot_path is not None:
            from brake_hil.report.segment_plots import plot_segments

            title = f"{recording_path.name}: {rig.name}"
            figures = tuple(plot_segments(comparison, plot_path, title))
        write_json(json_path, document)
    return CompareResult(
        recording_path, rig_path, rig, comparison, document, json_path, plot_path, figures
    )
