"""How the rig values a calibration fits are said, and what a move of one points to on the rig.

The calibration (:mod:`brake_hil.diagnosis.calibration`) fits multipliers of a few rig-file
values (``caliper_stiffness``, the seal's ``k_eh`` and ``c_eh`` ...). They are not effects (an
effect's words are in its catalogue entry, :mod:`brake_hil.physics.catalogue`), so their words
live here, once: the diagnosis report names a value far outside its tolerance with them, and
the trend of a rig's health names a value's drift or offset and its likely cause.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Final, NamedTuple

__all__ = ["VALUE_LABELS", "ValueLabel"]


class ValueLabel(NamedTuple):
    """How one calibrated rig value is said."""

    words: str  # e.g. "caliper stiffness"
    cause: str  # what a drift or an offset of it points to on the rig
    note: str = ""  # said in brackets after the words where the report explains the value

    @property
    def report_words(self) -> str:
        """The words with their note in brackets (the diagnosis report's calibration table)."""
        return f"{self.words} ({self.note})" if self.note else self.words


VALUE_LABELS: Final[Mapping[str, ValueLabel]] = {
    "caliper_stiffness": ValueLabel("caliper stiffness", "check the caliper mounting"),
    "valve_resistance": ValueLabel("needle-valve resistance", "the needle valve setting moved"),
    "effective_hydraulic_stiffness": ValueLabel(
        "seal stiffness k_eh", "seal wear", "from the seal values"
    ),
    "effective_hydraulic_damping": ValueLabel(
        "seal damping c_eh", "seal wear", "from the seal values"
    ),
    "air_fraction": ValueLabel("fluid air fraction", "air in the fluid: bleed the circuit"),
    "bore_compliance": ValueLabel("bore compliance C_b", "air in the fluid: bleed the circuit"),
    "hose_stiffness": ValueLabel("hose wall modulus", "hose ageing or a new hose"),
    "bore_area": ValueLabel(
        "caliper force area A_eb",
        "check the bore's area ratio in the rig file and the caliper's seating (uneven load)",
        "the share of the pressure force the caliper body sees",
    ),
    "piston_area": ValueLabel(
        "piston area A_ep",
        "check the piston diameter in the rig file",
        "the pistons' section: the pressure force on the pads, the fluid each stroke moves",
    ),
}
"""Every value the calibration may fit, by its name (a test holds it to the calibration)."""
