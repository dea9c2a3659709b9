"""The one small interface every candidate model of the diagnosis shares.

A candidate is the calibrated LTI model augmented with one piece of left-out physics. It
points to its entry of the effect catalogue (:mod:`brake_hil.physics.catalogue`: name,
physics, source, signature), declares its parameters (unit, bounds, start value, linear or
logarithmic search), describes its model of the physics, and fills a :class:`Draft` of the
engine's :class:`~brake_hil.diagnosis.engine.ModelSpec` for a batch of parameter vectors:
it scales LTI coefficients and adds terms through the engine's protocol
(:class:`~brake_hil.diagnosis.engine.Term`). Two candidates combine by filling the same draft
in turn.

The candidates are deliberately simpler than the virtual rig's physics (an ideal Jenkins
slider, not a rate-dependent bristle law; one lumped hose stage, not a ladder; isothermal,
not polytropic air; a pure ``Q |Q|`` orifice; one heating time, not two heat paths and a
viscosity law), so the benchmark does not fit the very equations that made its data. (The
hose stage's wall creeps as family b's hose node does, so for the hose family b is not an
independent check.)
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import ClassVar, NamedTuple

import numpy as np

from brake_hil.diagnosis.engine import ModelSpec, Term
from brake_hil.physics.catalogue import EffectEntry
from brake_hil.physics.parameters import (
    ModelParameters,
    SealProperties,
    chamber_volumes,
    derive_parameters,
    line_resistance,
    seal_properties,
)
from brake_hil.physics.rig import Rig
from brake_hil.types import FloatArray


class CandidateParameter(NamedTuple):
    """One fitted parameter of a candidate."""

    name: str
    unit: str
    low: float
    high: float
    start: float
    logarithmic: bool = False  # search on log(value) (positive quantities spanning decades)
    absent: float | None = None  # its value in a model file older than it (None: required)


@dataclass(frozen=True)
class Context:
    """What a candidate may know of the rig and the recording (never the label)."""

    seal: SealProperties  # per-seal F_fs, k_s (the paper's eqs. 2-3)
    bore_volume: float  # V_b, m^3 (eq. 20)
    flow_amplitude: float  # |Q_h| amplitude of the calibrated LTI model, m^3/s
    transducer_distance: float  # l_c, m
    bore_friction_coefficient: float  # nominal mu_fb
    time_reference: float  # s, middle of the training data (where drifts are zero)
    hose_resistance_share: float = 0.3  # -, R_t / (R_r + R_v + R_t): the hose's part of R
    reference_compliance: float = 5.0e-14  # m^3/Pa, C_b of the rig file at 0.9 MPa mean p_i
    last_time: float = 0.0  # s, recording time of the last sample diagnosed


def rig_context(
    rig: Rig, flow_amplitude: float, time_reference: float, last_time: float = 0.0
) -> Context:
    """The Context of a rig (eqs. 2-3, 13, 20 of the paper) for a flow and times (s)."""
    viscosity = rig.fluid.viscosity
    hose = line_resistance(rig.hose, viscosity)
    total = (
        line_resistance(rig.hard_pipe, viscosity)
        + rig.model_overrides.get("R_v", rig.needle_valve_resistance)
        + hose
    )
    return Context(
        seal=seal_properties(rig),
        bore_volume=chamber_volumes(rig)[1],
        flow_amplitude=flow_amplitude,
        transducer_distance=rig.transducer_distance,
        bore_friction_coefficient=rig.bore_friction_coefficient,
        time_reference=time_reference,
        hose_resistance_share=hose / total,
        reference_compliance=derive_parameters(rig).bore_compliance,
        last_time=last_time,
    )


@dataclass
class Draft:
    """A ModelSpec under construction for a batch of parameter vectors."""

    params: list[ModelParameters]
    terms: list[Term] = field(default_factory=list)

    @property
    def batch(self) -> int:
        """Number of parameter sets."""
        return len(self.params)

    def scale(self, name: str, factors: FloatArray) -> None:
        """Multiply one LTI coefficient of every set by its factor."""
        self.params = [
            p.with_changes(**{name: getattr(p, name) * float(f)})
            for p, f in zip(self.params, factors)
        ]

    def add(self, term: Term) -> None:
        """Add a term; one of its kind already there absorbs it (:meth:`Term.merge`)."""
        for k, present in enumerate(self.terms):
            if type(present) is type(term):
                self.terms[k] = present.merge(term)
                return
        self.terms.append(term)

    def spec(self) -> ModelSpec:
        """The finished ModelSpec."""
        return ModelSpec(tuple(self.params), tuple(self.terms))


class Candidate:
    """Base of the candidate models (see the modules beside this one)."""

    entry: ClassVar[EffectEntry]  # what the effect is (name, physics, source, signature)
    parameters: ClassVar[tuple[CandidateParameter, ...]]
    lead_in: ClassVar[float] = 0.0
    """History (s) a fit's run needs before its window for this physics' memory to forget the
    equilibrium the run starts from; the fit's own lead-in (``fitting.PREROLL``) serves what
    forgets faster."""
    kin_forms: ClassVar[frozenset[tuple[str, str]]] = frozenset()
    """Generic forms ``(form, channel)`` (:mod:`..residual_forms`) that are this physics in a
    free shape: one that describes the misfit as well does not make it unidentified."""
    own_rig_values: ClassVar[tuple[tuple[str, int], ...]] = ()
    """Calibrated rig values (``calibration.UNCERTAIN`` names) that are this physics' own, each
    with the sign of the log-multiplier this physics moves it by: a calibration that explains the
    recording only by moving one of them far that way out of its tolerance names this physics
    in the calibration's terms, not a parameter error (the wider-priors check of
    ``physics_checks``)."""
    lookahead: ClassVar[float] = 0.0
    """Future (s) its output transform reads (an output advanced in time): a fit's run goes
    on this long past its window, so the last samples of the window are simulated, not held at
    the run's final value (``fitting.Model``)."""
    contains: ClassVar[frozenset[str]] = frozenset()
    """Candidates this one's law holds as a special case (the groove at ``a = 0`` is plain
    stick-slip): a pair of it with one of them is no second physics and is not fitted."""
    even_harmonics: ClassVar[bool] = False
    """Its law can make the bore pressure's even harmonics on a symmetric cycle (it differs
    between apply and release, or changes with the pressure: air's compliance, a load share, a
    groove asymmetry). A law the same both ways (linear, stick-slip, Coulomb friction, an
    orifice) cannot: named alone beside even harmonics it does not make, it is likely not alone
    (:attr:`.summary.Summary.unmade`)."""
    retired_parameters: ClassVar[tuple[str, ...]] = ()
    """Parameter names of an older law of this physics that no longer means the same: a model
    file that has one is refused (``improved_model``), not run with another meaning."""

    @property
    def name(self) -> str:
        """The effect's name (its catalogue entry's)."""
        return self.entry.name

    @property
    def signature(self) -> str:
        """How the effect shows in a recording (its catalogue entry's)."""
        return self.entry.signature

    def fill(self, draft: Draft, theta: FloatArray, context: Context) -> None:
        """Add this physics to ``draft`` for parameter rows ``theta`` (B, P)."""
        raise NotImplementedError

    def consistent(self, evidence: dict[str, float]) -> bool:
        """Whether the measured evidence shows this candidate's signature."""
        return True

    def plausible(self, theta: FloatArray) -> bool:
        """Whether fitted parameters ``theta`` (this candidate's own) describe this physics.

        False when they are a stand-in for something else (e.g. a common delay of every
        output is a dynamics error, not an acquisition skew).
        """
        return True

    def segments_disagree(self, per_segment: FloatArray) -> str | None:
        """What no constant of this physics would do, in words; None when the segments agree.

        ``per_segment`` holds its own parameters fitted on each training segment alone (one
        row per segment, in time order). The segments check (``physics_checks``) first
        applies its generic test (every parameter within its uncertainty and a share of its
        search range); a candidate whose physics fixes a value more tightly says so here.
        """
        return None

    def rivals(self, theta: FloatArray) -> tuple[Rival, ...]:
        """Physics outside the library that this one, fitted with ``theta``, may stand in for.

        The rival check of ``physics_checks`` fits the same hypothesis with this member
        replaced by each rival, calibration refitted. Default: none.
        """
        return ()

    def not_alone(self, theta: FloatArray) -> str | None:
        """What its fitted own parameters ``theta`` show beside this physics, in words.

        A fit can carry, besides this physics, a part no instance of it makes: then it is
        likely not alone in the recording (named alone, the verdict is no surer than
        ``diagnose.STAND_IN_MARGIN`` allows). Default: None, nothing beside it.
        """
        return None

    def start(self, context: Context) -> FloatArray:
        """Start values of the parameters (may use the rig's derived quantities)."""
        return np.array([p.start for p in self.parameters])

    def other_starts(self, context: Context) -> tuple[FloatArray, ...]:
        """Start values beside :meth:`start` a fit of this candidate alone also tries.

        For a law whose fit can slide from its start to a degenerate corner (the better
        training fit is kept, :func:`..fitting.fit_from_both`). Default: none.
        """
        return ()

    @classmethod
    def describe(cls) -> str:
        """The physical description: the class docstring's first paragraphs, one line."""
        return " ".join((cls.__doc__ or "").split())


class Rival(Candidate):
    """Physics outside the library that mimics a candidate's (never named, not registered).

    Fitted in the candidate's place, it says whether its fitted values are its own physics
    (:meth:`holds`); when they are, the candidate must leave ``told_apart`` times less
    held-out error than it to be told from it (:func:`..physics_checks.rival_check`).
    """

    told_apart: ClassVar[float] = 1.0
    why: ClassVar[str] = ""
    """What the candidate's physics cannot do and the rival's does, in words."""
    unlike: ClassVar[str] = "not that physics"
    """What its fitted values say when they are not its physics (:meth:`holds`), in words."""
    stands_for: ClassVar[str] = ""
    """The library effect whose physics it is, as a special case (a late ``p_i`` is a
    ``sensor_delay`` with every output leading); "" for physics outside the library. A
    hypothesis it ties with is not told from that effect (:mod:`..ties`)."""

    def holds(self, theta: FloatArray) -> bool:
        """Whether its fitted own parameters ``theta`` describe the rival's physics."""
        return True

    def in_words(self, theta: FloatArray) -> str:
        """Its fitted own parameters, read physically."""
        return ", ".join(f"{p.name} {v:.3g} {p.unit}" for p, v in zip(self.parameters, theta))


def own_columns(
    members: Iterable[Candidate], values: FloatArray
) -> Iterator[tuple[Candidate, FloatArray]]:
    """Each candidate with its own parameters' columns of ``values`` (the last axis).

    A fitted parameter vector (or rows of them) holds the candidates' own parameters first,
    one after another in ``members``' order (``Model.effect_size``), then the calibration's.
    """
    column = 0
    for member in members:
        size = len(member.parameters)
        yield member, values[..., column : column + size]
        column += size
