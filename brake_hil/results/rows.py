"""What the results database gives back: a stored diagnosis, its values, a failed run."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
import re

from brake_hil.diagnosis.verdict import confidence_text

__all__ = [
    "CalibrationValue",
    "DiagnosisRow",
    "FailedRun",
    "HypothesisRow",
    "MetricsRun",
    "Metrics",
]

Metrics = Mapping[str, Mapping[str, Mapping[str, float]]]
"""Model name -> channel -> metric -> value (the paper's Table 4-5 metrics)."""


@dataclass(frozen=True)
class CalibrationValue:
    """One calibrated rig value of a diagnosis."""

    name: str  # e.g. caliper_stiffness
    multiplier: float  # calibrated LTI model's value over the rig file's (1 = nominal)
    prior_sigma: float  # the rig file's tolerance (log-sigma)
    posterior_sigma: float  # after the data (log-sigma; inf: not identified at all)
    improved_multiplier: float | None  # the improved model's value over the rig file's


@dataclass(frozen=True)
class HypothesisRow:
    """One hypothesis a diagnosis fitted: an effect or a pair (``a+b``)."""

    effect: str
    named: bool  # every effect of it is in the verdict
    held_out_improvement: float  # held-out mean squared error, baseline over hypothesis
    score: float  # log improvement less a charge per parameter
    parameters: Mapping[str, float]  # fitted, SI units


@dataclass(frozen=True)
class DiagnosisRow:
    """One stored diagnosis: the recording, the rig file, the verdict and its numbers."""

    run_id: int
    recording_path: str
    recording_hash: str
    start_ns: int | None  # first log time (ns since the epoch)
    end_ns: int | None  # last log time (ns since the epoch)
    rig_name: str
    rig_hash: str
    rig_path: str
    tool_version: str
    written_at: str  # ISO 8601, UTC
    effects: tuple[str, ...]  # the verdict
    confidence: float  # 0-1
    explanation: str
    calibration: tuple[CalibrationValue, ...]
    hypotheses: tuple[HypothesisRow, ...]
    metrics: Metrics  # model (baseline, improved) -> channel -> metric -> value

    @property
    def confidence_text(self) -> str:
        """The confidence as the diagnosis said it: a number, or a capped one's words."""
        capped = _CAPPED.search(self.explanation)
        return confidence_text(self.confidence, capped and (capped.group(1) or capped.group(2)))


_CAPPED = re.compile(
    r"How sure: (?:likely, (.+?); the confidence is that rule's cap"
    r"|\d\.\d\d, (.+?): how often verdicts like this one)"
)
"""A rule's doubt in a stored explanation (:func:`.diagnosis.result.explain`'s words, as
written now and by versions that printed a capped confidence as words only)."""


@dataclass(frozen=True)
class FailedRun:
    """A command that failed on a recording: stored so, never as a result."""

    run_id: int
    kind: str
    recording_path: str
    rig_name: str
    tool_version: str
    written_at: str  # ISO 8601, UTC
    error: str  # its one line


@dataclass(frozen=True)
class MetricsRun:
    """One stored regression or comparison: the recording, the rig file, the metrics."""

    run_id: int
    kind: str  # regression or comparison
    recording_path: str
    recording_hash: str
    rig_name: str
    rig_hash: str
    tool_version: str
    written_at: str  # ISO 8601, UTC: when it ran (a nightly replays the same recording)
    metrics: Metrics  # model -> channel -> metric -> value
