"""zero_wander: the force and displacement transducers' zeros moving (a rival, not an effect).

Not a library effect and never named. The physics checks fit it, with the calibration
refitted, as the rival of a thermal drift (``ThermalDrift.rivals``): a seal softening as the
rig warms moves the mean ``F_k`` and ``x_c`` over the recording, and so does a transducer
whose zero walks within its stability (``ZERO_STABILITY`` of its full scale, a few times its
noise). When zeros moving steadily within that stability explain the misfit nearly as well,
the drift is not told from the transducers.
"""

from __future__ import annotations

import numpy as np

from brake_hil.diagnosis.candidates.base import CandidateParameter, Context, Draft, Rival
from brake_hil.diagnosis.dataset import zero_stability as stability
from brake_hil.diagnosis.engine import WanderingZeros
from brake_hil.diagnosis.thresholds import CLEAR_ACCEPT_RATIO
from brake_hil.physics.catalogue import EffectEntry, Quantity
from brake_hil.types import FloatArray

WANDERING = ("F_k", "x_c")
"""The channels whose zeros it moves: those a seal's drift moves in level (``p_b``'s zero is
read on the measured one already, ``dataset.read_as_measured``)."""
SEARCHED_STABILITIES = 5.0
"""Its wander is searched up to this many times the zero's stability, so that a wander beyond
the stability comes out as such (and is not a transducer's) instead of at the bound."""


ZERO_WANDER = EffectEntry(
    name="zero_wander",
    title="the force and displacement transducers' zeros moving during the recording",
    physics=(
        "A strain-gauge load cell and a displacement probe, zeroed before the run, drift by "
        "their thermal zero shift as they warm: the readings of F_k and x_c move by an offset "
        "that grows over the recording while their dynamics are unchanged."
    ),
    source="transducer datasheets: thermal zero shift, 0.01-0.02 % of full scale per kelvin",
    signature="F_k's and x_c's levels moving over the recording, amplitudes and phases alike",
    channels=WANDERING,
    quantities=(
        Quantity("dF", "N", "F_k's zero at the last sample, from the training data's middle"),
        Quantity("dx", "m", "x_c's zero at the last sample, from the training data's middle"),
    ),
)


class ZeroWander(Rival):
    """``F_k``'s and ``x_c``'s zeros moving steadily from the training data's middle."""

    entry = ZERO_WANDER
    parameters = tuple(
        CandidateParameter(
            f"{channel}_zero_wander",
            unit,
            -SEARCHED_STABILITIES * stability(channel),
            SEARCHED_STABILITIES * stability(channel),
            0.0,
        )
        for channel, unit in zip(WANDERING, ("N", "m"))
    )
    told_apart = CLEAR_ACCEPT_RATIO
    """A drift must leave this many times less held-out error than the moving zeros: the bar a
    candidate clears over a baseline clearly above the noise, these being a baseline whose
    transducers' zeros move as transducers do."""
    why = "a drifting rig changes amplitudes and phases too, moving zeros do not"
    unlike = "beyond a transducer's zero stability"

    def holds(self, theta: FloatArray) -> bool:
        """Every zero within its transducer's stability."""
        return all(
            abs(float(value)) <= stability(channel) for channel, value in zip(WANDERING, theta)
        )

    def in_words(self, theta: FloatArray) -> str:
        """``zeros moving by 1.2 N (F_k) and 0.04 um (x_c)``."""
        return (
            f"the transducers' zeros moving by {float(theta[0]):.2g} N (F_k) and "
            f"{1e6 * float(theta[1]):.2g} um (x_c) over the recording"
        )

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Move the zeros at the rates that reach the fitted wander at the last sample."""
        span = max(context.last_time - context.time_reference, 1.0)
        rates = np.zeros((draft.batch, 3))
        rates[:, 1] = theta[:, 0] / span
        rates[:, 2] = theta[:, 1] / span
        reference = np.full(draft.batch, context.time_reference)
        draft.add(WanderingZeros(rates, reference))
