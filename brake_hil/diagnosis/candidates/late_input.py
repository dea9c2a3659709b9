"""late_input: ``p_i`` acquired late through its filter (a rival, not an effect).

Not a library effect of its own (``sensor_delay`` names a late ``p_i`` as every output leading
alike) and never named. The physics checks fit it, with the calibration refitted, as the rival
of a hose (``HoseCompliance.rivals``): a hose's compliance adds lag between ``p_i`` and every
output, and a refitted calibration with less lag of its own (less air, a freer valve) plus a
creeping hose can mimic a late ``p_i``'s lead. When every output led alike explains the
misfit nearly as well, the hose is not told from a late input.
"""

from __future__ import annotations

from brake_hil.diagnosis.candidates.base import CandidateParameter, Context, Draft, Rival
from brake_hil.diagnosis.engine import LeadingOutputs
from brake_hil.physics.catalogue import EffectEntry, Quantity
from brake_hil.topics import OUTPUT_CHANNELS
from brake_hil.types import FloatArray

LONGEST_ADVANCE = 0.02
"""s, the bound of the fitted advance of ``p_i``."""
SHORTEST_LEAD = 0.5e-3
"""s: a lead (advance plus filter) shorter than this is no late input (``sensor_delay``'s
skew threshold)."""

LATE_INPUT = EffectEntry(
    name="late_input",
    title="the master-cylinder pressure acquired late through its filter",
    physics=(
        "The p_i channel passes an anti-alias filter and a slower path than the outputs (a "
        "multiplexer, a gateway), so the model, driven by the p_i it reads, predicts every "
        "output late by the same time; the outputs lead the prediction alike."
    ),
    source="the paper's tau of a few per cent of 200 ms; any DAQ's channel skew",
    signature="every output ahead of the prediction by the same time, amplitudes unchanged",
    channels=OUTPUT_CHANNELS,
    quantities=(
        Quantity("a", "s", "pure delay of p_i beyond the outputs'"),
        Quantity("T", "s", "time constant of its first-order filter"),
    ),
)


class LateInput(Rival):
    """Every output advanced by ``a`` and led by ``T``: a ``p_i`` late through a filter."""

    entry = LATE_INPUT
    parameters = (
        CandidateParameter("input_advance", "s", 0.0, LONGEST_ADVANCE, 0.002),
        CandidateParameter("input_filter_time", "s", 0.0, 0.01, 0.0005),
    )
    lookahead = LONGEST_ADVANCE + 1e-3  # and a sample for the leading slope
    told_apart = 1.5
    """A hose must leave this many times less held-out error than a late ``p_i`` (the bar a
    candidate clears over a baseline clearly above the noise, ``CLEAR_ACCEPT_RATIO``): fitted in
    a hose's place, a true late ``p_i`` leaves about the hose's error or less, and on the few
    true hoses where it holds at all a late ``p_i`` leaves more than this (evidence in
    docs/diagnosis.md)."""
    why = "a hose adds lag to every output, it cannot make them lead"
    stands_for = "sensor_delay"
    unlike = "too short a lead for a late input"

    def holds(self, theta: FloatArray) -> bool:
        """A lead of at least ``SHORTEST_LEAD`` in all."""
        return float(theta[0] + theta[1]) >= SHORTEST_LEAD

    def in_words(self, theta: FloatArray) -> str:
        """``p_i 3.3 ms late (0.1 ms delay, 3.2 ms filter)``."""
        return (
            f"p_i acquired {1e3 * float(theta[0] + theta[1]):.1f} ms late ({1e3 * theta[0]:.1f} "
            f"ms delay, a {1e3 * theta[1]:.1f} ms filter)"
        )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Lead every output."""
        draft.add(LeadingOutputs(theta[:, 0].copy(), theta[:, 1].copy()))
