"""What a chain run produced, and the recorded predictions checked against the batch model.

No rclpy.
"""

from __future__ import annotations

from dataclasses import dataclass, field
import json
from pathlib import Path
from typing import Any

import numpy as np

from brake_hil.errors import RecordingError
from brake_hil.io.recording_reader import list_topics, read_recording
from brake_hil.live.model import LiveModel
from brake_hil.topics import MASTER_CYLINDER_PRESSURE, OUTPUT_CHANNELS, PREDICTED_OUTPUTS

__all__ = ["ChainResult", "check_recorded_predictions", "read_json"]


@dataclass(frozen=True)
class ChainResult:
    """What a chain run produced."""

    out_dir: Path
    comparator: dict[str, Any] | None = None  # comparator summary
    model: dict[str, Any] | None = None  # caliper model timing statistics
    bag: Path | None = None  # the recorder's MCAP directory
    check: dict[str, float] | None = None  # recorded predictions against the batch model
    missing: tuple[str, ...] = ()  # nodes not available
    exit_codes: dict[str, int] = field(default_factory=dict)
    cpu_s: dict[str, float] = field(default_factory=dict)  # CPU time of each node (s)
    wall_s: float = 0.0  # from the source's start to the stop (s)
    logs: Path | None = None  # the nodes' log files
    source: dict[str, Any] | None = None  # pressure source summary
    expected: int | None = None  # input samples the source was to publish (None: unknown)

    @property
    def failed(self) -> dict[str, int]:
        """Nodes that exited with a non-zero status, and the status."""
        return {name: code for name, code in self.exit_codes.items() if code != 0}

    def sample_losses(self) -> tuple[bool, str]:
        """Whether every input sample was predicted and recorded, and one line saying so.

        Counts the source's published ``p_i`` samples against the run's (``expected``: a
        source stopped before the end of its run, by a timeout on a starved machine, is a
        failure), the model's predictions and, with a recording, the recorded inputs and
        predictions. Without the source's or the model's summary nothing can be said: that is a
        failure too ("I don't know").
        """
        if self.source is None or self.model is None:
            absent = [n for n, d in (("source", self.source), ("model", self.model)) if d is None]
            absent_text = " or ".join(absent)
            return False, f"cannot tell whether samples were lost: no {absent_text} summary"
        published = int(self.source["published"])
        predictions = int(self.model["counters"]["predictions"])
        unpredicted = published - predictions
        short = self.expected is not None and published != self.expected
        of_run = f" of the run's {self.expected}" if short else ""
        parts = [f"{published}{of_run} samples published, {predictions} predicted"]
        parts[0] += f" ({unpredicted} unpredicted)" if unpredicted else ""
        lost = 0
        if self.check is not None:
            inputs, recorded = int(self.check["inputs"]), int(self.check["predictions"])
            lost = (published - inputs) + (predictions - recorded)
            parts.append(f"{inputs} inputs and {recorded} predictions recorded ({lost} lost)")
        elif self.bag is not None:
            return False, f"{parts[0]}; the recording could not be checked"
        whole = unpredicted == 0 and lost == 0
        verdict = "every sample predicted and recorded" if whole else "samples were lost"
        if short and whole:
            verdict = "the run was cut short"
        ok = whole and not short
        return ok, f"{verdict}: " + "; ".join(parts)


def read_json(path: Path) -> dict[str, Any] | None:
    """The JSON object in ``path``; None when it is missing, unreadable or not an object."""
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return document if isinstance(document, dict) else None


def check_recorded_predictions(bag: Path, model: LiveModel) -> dict[str, float]:
    """Recorded predictions against the batch ``model`` (the run's) on the recorded ``p_i``.

    Returns the input and prediction counts (from the files' indexes, so a recording that lost
    samples is counted, not refused) and, when they agree, per channel the largest deviation
    over the batch output's peak-to-peak (float rounding: ~1e-13).
    """
    topics = {t.name: t for t in list_topics(bag)}
    missing = [
        spec.name
        for spec in (MASTER_CYLINDER_PRESSURE, PREDICTED_OUTPUTS[0])
        if spec.name not in topics
    ]
    check: dict[str, float] = (
        {
            "inputs": float(topics[MASTER_CYLINDER_PRESSURE.name].message_count),
            "predictions": float(topics[PREDICTED_OUTPUTS[0].name].message_count),
        }
        if not missing
        else {"inputs": 0.0, "predictions": 0.0}
    )
    if missing or check["inputs"] != check["predictions"]:
        return check  # samples missing from the recording: counted, nothing more to compare
    try:
        recorded = read_recording(bag, required=(MASTER_CYLINDER_PRESSURE, *PREDICTED_OUTPUTS))
    except RecordingError:
        return check  # e.g. a gap where both lost the same samples: the counts say it
    batch = model.batch(recorded.master_cylinder_pressure)
    predicted = (
        recorded.predicted_bore_pressure,
        recorded.predicted_block_force,
        recorded.predicted_caliper_displacement,
    )
    for channel, live, offline in zip(OUTPUT_CHANNELS, predicted, batch):
        assert live is not None
        check[f"max_dev_{channel}"] = float(np.max(np.abs(live - offline)) / np.ptp(offline))
    return check
