"""Candidate models of the diagnosis, one module per effect of interface.md."""

from __future__ import annotations

from brake_hil.diagnosis.candidates.base import Candidate
from brake_hil.diagnosis.candidates.bore_friction import BoreFriction
from brake_hil.diagnosis.candidates.eccentric_load import EccentricLoad
from brake_hil.diagnosis.candidates.entrained_air import EntrainedAir
from brake_hil.diagnosis.candidates.hose_compliance import HoseCompliance
from brake_hil.diagnosis.candidates.orifice_flow import OrificeFlow
from brake_hil.diagnosis.candidates.seal_groove_asymmetry import SealGrooveAsymmetry
from brake_hil.diagnosis.candidates.seal_stick_slip import SealStickSlip
from brake_hil.diagnosis.candidates.sensor_delay import SensorDelay
from brake_hil.diagnosis.candidates.thermal_drift import ThermalDrift

CANDIDATES: tuple[Candidate, ...] = (
    SealStickSlip(),
    SealGrooveAsymmetry(),
    EntrainedAir(),
    OrificeFlow(),
    HoseCompliance(),
    BoreFriction(),
    EccentricLoad(),
    ThermalDrift(),
    SensorDelay(),
)
"""Every candidate, in the order of interface.md's effect table."""

BY_NAME = {candidate.name: candidate for candidate in CANDIDATES}
