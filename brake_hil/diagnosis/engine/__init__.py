"""Simulator of the diagnosis's candidate models: the LTI caliper model plus left-out physics.

The diagnosis fits many candidate models, each many times, so the engine runs a *batch* of
parameter sets in one pass (one pass gives a whole finite-difference Jacobian):

* The linear part (eq. 21c-f) is discretised exactly with a first-order hold on ``p_i``, as
  :mod:`brake_hil.physics.lti_model` does (:mod:`.plant`); a model whose terms are all linear
  runs through that model's vectorised modal simulation.
* Everything else comes as terms through one small protocol (:mod:`.terms`): changes of the
  linear plant per schedule entry (tabulated over bore pressure, time blocks and the terms'
  discrete modes; each step takes its entry), explicit inputs held over a step (exponential
  integrator), state updates after a step, and transforms of the outputs.
* The mechanisms more than one effect uses are the engine's own (:mod:`.mechanisms`): a
  switching Jenkins friction element between piston and caliper, a per-channel delay; and,
  for the physics checks' rivals, a channel read through a mode, every output led alike and
  the outputs' zeros wandering.

A candidate of :mod:`brake_hil.diagnosis.candidates` contributes terms; the engine knows no
effect names.
"""

from __future__ import annotations

from brake_hil.diagnosis.engine.integrator import Integrator, simulate_batch
from brake_hil.diagnosis.engine.mechanisms import (
    ChannelDelay,
    ChannelReading,
    FrictionElement,
    LeadingOutputs,
    WanderingZeros,
    tustin_mode,
)
from brake_hil.diagnosis.engine.plant import CALIPER_FORCE, LINE_DROP, RELATIVE_FORCE, Coupling
from brake_hil.diagnosis.engine.terms import Entry, MidStep, ModelSpec, State, Step, Term

__all__ = [
    "CALIPER_FORCE",
    "LINE_DROP",
    "MidStep",
    "RELATIVE_FORCE",
    "ChannelDelay",
    "ChannelReading",
    "Coupling",
    "Entry",
    "FrictionElement",
    "Integrator",
    "LeadingOutputs",
    "ModelSpec",
    "State",
    "Step",
    "Term",
    "WanderingZeros",
    "tustin_mode",
    "simulate_batch",
]
