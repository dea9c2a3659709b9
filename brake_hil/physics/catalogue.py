"""The catalogue of effects: the physics the seed's LTI model leaves out, one entry each.

An entry is what every part of brake_hil agrees an effect *is*: its name (interface.md's
effect table), the physics in words, where that physics is written down, how it shows in a
recording, which measured channels it reaches, the physical quantities it is described by
with their units, and what the reports say of it (the rig check of the diagnosis report, the
trend's words and cause, the calibrated values its misfit shows up in). Three things point to
each entry:

* the virtual rig's *truth laws* (:mod:`brake_hil.virtual_rig.effects` and
  :mod:`brake_hil.virtual_rig.family_b`, two structurally different ones), the richer
  physics that makes test recordings;
* the diagnosis's *candidate* (:mod:`brake_hil.diagnosis.candidates`), the simpler model
  fitted to a recording.

Adding an effect is one entry here (:func:`register` for one made at run time), a truth law
of each family and one candidate (CONTRIBUTING.md); each registers itself. Physics outside
the library (what ``unexplained`` is tested on) has entries in :data:`OUT_OF_LIBRARY`: a
truth law and no candidate.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Generic, NamedTuple, TypeVar

from brake_hil.errors import EffectError

__all__ = [
    "CATALOGUE",
    "OUT_OF_LIBRARY",
    "EffectEntry",
    "EntryRegistry",
    "Quantity",
    "effect_names",
    "entry",
    "entry_text",
    "register",
    "stand_ins",
    "unregister",
]

CHANNELS = ("p_b", "F_k", "x_c")
"""The measured outputs an effect can reach."""


class Quantity(NamedTuple):
    """A physical quantity an effect is described by."""

    symbol: str  # as the seed or the physics text writes it
    unit: str  # SI, "-" for dimensionless
    meaning: str


@dataclass(frozen=True)
class EffectEntry:
    """One effect of the library (or out of it): what its truth laws and candidate point to."""

    name: str  # interface.md's effect name
    title: str  # one line
    physics: str  # what happens, in words
    source: str  # where the physics is written (seed equation, paper, textbook)
    signature: str  # how it shows in a recording
    channels: tuple[str, ...]  # the measured outputs its physics reaches
    quantities: tuple[Quantity, ...]  # what it is described by, with units
    rig_check: str = ""  # what to look at on the rig when a diagnosis names it
    label: str = ""  # how a trend names it, e.g. "seal stick-slip" (empty: the title)
    cause: str = ""  # what a growing strength of it points to on the rig
    stands_in_for: tuple[str, ...] = ()  # calibrated values its misfit shows up in

    def __post_init__(self) -> None:
        if unknown := [c for c in self.channels if c not in CHANNELS]:
            raise EffectError(f"effect {self.name}: unknown channel {unknown[0]!r}")

    def describe(self) -> str:
        """Title, physics, source and signature as one paragraph."""
        return (
            f"{self.name}: {self.title}. {self.physics} Source: {self.source}. "
            f"Signature: {self.signature}."
        )


class _Catalogue(Mapping[str, EffectEntry]):
    """Entries by name, in the order they were registered (interface.md's table first)."""

    def __init__(self, entries: tuple[EffectEntry, ...]) -> None:
        self._entries = {item.name: item for item in entries}

    def __getitem__(self, name: str) -> EffectEntry:
        return self._entries[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def add(self, item: EffectEntry) -> None:
        if item.name in self._entries:
            raise EffectError(f"effect {item.name} is already in the catalogue")
        self._entries[item.name] = item

    def remove(self, name: str) -> None:
        self._entries.pop(name, None)


def _q(symbol: str, unit: str, meaning: str) -> Quantity:
    return Quantity(symbol, unit, meaning)


CATALOGUE = _Catalogue(
    (
        EffectEntry(
            name="seal_stick_slip",
            title="Coulomb friction at the piston seals with stick and slip",
            physics=(
                "Each rectangular seal shears as a spring of stiffness k_s while its inner face "
                "sticks to the piston, and slides once the shear force reaches the static "
                "friction threshold F_fs, in place of the equivalent viscous k_eh, c_eh."
            ),
            source=(
                "seed eqs. 2-6 and its two-valued stiffness; LuGre (Canudas de Wit et al., IEEE "
                "TAC 40(3), 1995) for the truth law"
            ),
            signature=(
                "k_eh from characterize falls as the pressure amplitude grows; super-harmonics "
                "grow from p_i to x_c; the loop of seal force against seal displacement is a "
                "parallelogram with flat slipping edges; at low amplitude the rig is stiffer "
                "than the paper's k_eh* = 0.29"
            ),
            channels=("F_k", "x_c"),
            quantities=(
                _q("k_s", "N/m", "shear stiffness of one seal while stuck"),
                _q("F_fs", "N", "static friction threshold of one seal"),
                _q("phi", "-", "share of the seal force carried by friction"),
            ),
            rig_check="the piston seals: wear, swell, groove fill and lubrication",
            label="seal stick-slip",
            cause="seal wear",
            stands_in_for=("effective_hydraulic_stiffness", "effective_hydraulic_damping"),
        ),
        EffectEntry(
            name="seal_groove_asymmetry",
            title="seal stiffness or slip threshold differs between apply and release",
            physics=(
                "Grooves chamfered on the pressure side let the seal shear easily as the piston "
                "moves out and roll it back more stiffly, about a relaxed position that creeps."
            ),
            source="seed, section 'Characterisation of k_eh' (named and ignored there)",
            signature=(
                "even harmonics (10, 20 Hz) in x_c and F_k that p_i lacks; a lopsided x_c "
                "waveform (apply and release halves differ); the mean x_c shifted"
            ),
            channels=("F_k", "x_c"),
            quantities=(
                _q("a", "-", "asymmetry: stiffness (1 - a) on apply, (1 + a) on release"),
                _q("tau_r", "s", "creep time of the seal's relaxed position"),
            ),
            rig_check="the seal grooves: chamfers and the seal's fit on each side",
            label="seal groove asymmetry",
            cause="seal wear",
            stands_in_for=("effective_hydraulic_stiffness", "effective_hydraulic_damping"),
        ),
        EffectEntry(
            name="entrained_air",
            title="a bulk modulus that rises with pressure (air compressed in the fluid)",
            physics=(
                "Air bubbles in the fluid compress with pressure, so the chamber's compliance "
                "is large at low pressure and small at high, instead of eq. 18's value at one "
                "mean pressure."
            ),
            source="seed eq. 18 (linearised there); Boyle's law, polytropic for the truth law",
            signature=(
                "p_b lower and later than predicted at low pressure, the mismatch shrinking as "
                "the mean pressure grows; p_b flattened at its troughs (super-harmonics)"
            ),
            channels=("p_b", "F_k", "x_c"),
            quantities=(_q("j", "-", "free-air volume fraction of the fluid at gauge zero"),),
            rig_check="air in the hydraulic line: bleed the caliper and the hose",
            label="entrained air",
            cause="air in the fluid: bleed the circuit",
            stands_in_for=("air_fraction", "bore_compliance"),
        ),
        EffectEntry(
            name="orifice_flow",
            title="a quadratic, turbulent pressure drop across the needle valve",
            physics=(
                "Past a throttling needle the flow separates and the drop follows the orifice "
                "equation dp = rho Q |Q| / (2 C_d^2 A^2), not the linear R_v Q."
            ),
            source="seed eqs. 15-16 (linearised there); Merritt 1967, eq. 3-6",
            signature=(
                "p_b's peak-to-peak falls short of the prediction more as the flow amplitude "
                "grows; p_b lags more at large amplitude and is flattened near its turning "
                "points (a 3rd harmonic p_i lacks)"
            ),
            channels=("p_b", "F_k", "x_c"),
            quantities=(_q("K", "Pa s^2/m^6", "orifice coefficient of dp = K Q |Q|"),),
            rig_check="the needle valve: its setting and whether it is partly blocked",
            label="turbulent valve flow",
            cause="the valve's flow regime changed",
            stands_in_for=("valve_resistance",),
        ),
        EffectEntry(
            name="hose_compliance",
            title="compliance of the hose between master cylinder and bore (an extra RC stage)",
            physics=(
                "A braided hose swells with pressure and stores fluid between the valve and the "
                "bore, which eq. 21c neglects (eq. 18 folds the walls into the bore's modulus); "
                "its rubber is viscoelastic, so part of the swell follows with a delay."
            ),
            source="seed eqs. 13, 18, 21c; Covas et al. (2004) for the wall's creep",
            signature=(
                "p_b lags p_i more and its peak-to-peak is lower than predicted, more at higher "
                "frequency; F_k and x_c follow p_b; the mismatch hardly depends on pressure"
            ),
            channels=("p_b", "F_k", "x_c"),
            quantities=(
                _q("C_h", "m^3/Pa", "compliance of the hose node, stored at once"),
                _q("C_d", "m^3/Pa", "the hose wall's retarded compliance"),
                _q("tau_w", "s", "the wall's retardation time"),
            ),
            rig_check="the hose: its type, length and age (a hose that swells)",
            label="hose compliance",
            cause="hose ageing or a new hose",
            stands_in_for=("hose_stiffness",),
        ),
        EffectEntry(
            name="bore_friction",
            title="Coulomb friction at the piston-bore contact from caliper cocking",
            physics=(
                "As the caliper rotates by x_c / l_c the bore wall presses on the piston with a "
                "normal force ~ A_eb p_b |x_c| / l_c; sliding against it costs Coulomb friction."
            ),
            source="seed eq. 8; Dahl (1968) for the truth law's presliding",
            signature=(
                "extra damping that grows with p_b |x_c|: c_eh and eta_eh above the prediction, "
                "the high-pressure segments lose more amplitude in x_c and F_k than the low"
            ),
            channels=("F_k", "x_c"),
            quantities=(_q("mu_fb", "-", "piston-bore friction coefficient"),),
            rig_check="the piston bores: scoring, dirt, alignment of the pistons",
            label="bore friction",
            cause="caliper cocking: check the piston and bore",
        ),
        EffectEntry(
            name="eccentric_load",
            title="the caliper sees a share of the pressure force that may shift with load",
            physics=(
                "When the block's centre of force is off the pistons' axis, moment arms make the "
                "support columns carry part of the load, so the caliper body sees s A_eb p_b."
            ),
            source="seed eq. 22",
            signature=(
                "x_c's amplitude and mean are mispredicted while p_b and F_k are right; the "
                "error grows with load; x_c's phase unchanged"
            ),
            channels=("x_c",),
            quantities=(
                _q("s0", "-", "change of the caliper's force share at the reference load"),
                _q("s1", "-", "change of the share per reference pressure"),
            ),
            rig_check="the caliper's alignment and the washers' seating (uneven load)",
            label="eccentric load",
            cause="check the load path",
        ),
        EffectEntry(
            name="thermal_drift",
            title="parameters drifting during the recording (fluid viscosity, seal modulus)",
            physics=(
                "As the rig warms up, brake-fluid viscosity falls (Andrade) and the seal "
                "softens, so the line resistance and the seal's k_eh, c_eh drift during a run."
            ),
            source="seed eqs. 6, 13; Andrade's viscosity law for the truth law",
            signature=(
                "a mismatch that grows steadily over the recording whatever the pressure; the "
                "same pressure segment repeated late does not match its early twin"
            ),
            channels=("p_b", "F_k", "x_c"),
            quantities=(
                _q("r_R", "1/s", "relative drift rate of the line resistance"),
                _q("r_s", "1/s", "relative drift rate of k_eh and c_eh"),
            ),
            rig_check="the temperature of fluid and caliper: let the rig warm up, log it",
            label="thermal drift",
            cause="temperature not settled",
        ),
        EffectEntry(
            name="sensor_delay",
            title="a measured channel lags the others (acquisition skew)",
            physics=(
                "Multiplexed DAQs, anti-alias filters and CAN gateways delay channels by "
                "different times."
            ),
            source="acquisition chain (not in the paper)",
            signature=(
                "one channel's tau / T offset from the others' by delay / T, the same in every "
                "segment and at every pressure; amplitudes agree"
            ),
            channels=("p_b", "F_k", "x_c"),
            quantities=(_q("d", "s", "delay of a channel relative to p_i"),),
            rig_check="the DAQ channel of the late sensor: its filter and sample timing",
            label="sensor delay",
            cause="DAQ timing",
        ),
    )
)
"""Every effect of interface.md's table (less ``unexplained``), in its order."""

OUT_OF_LIBRARY = _Catalogue(
    (
        EffectEntry(
            name="sensor_nonlinearity",
            title="a load cell whose gain grows with load",
            physics="The sensor's output is x (1 + c x): a static nonlinear map of one channel.",
            source="measurement chain (not in the paper)",
            signature=(
                "one output's amplitude ratio to the others grows with the pressure; its phase "
                "and the other channels unchanged"
            ),
            channels=("F_k",),
            quantities=(_q("c", "1/unit", "relative gain change per unit of the reading"),),
        ),
    )
)
"""Physics no candidate models: a case with it is labelled ``unexplained``."""


class _EntryText(Mapping[str, str]):
    """One text field of the library's entries, by name, for those that set it (a live view)."""

    def __init__(self, field: str) -> None:
        self._field = field

    def __getitem__(self, name: str) -> str:
        text = getattr(CATALOGUE[name], self._field)
        if not isinstance(text, str) or not text:
            raise KeyError(name)
        return text

    def __iter__(self) -> Iterator[str]:
        return (name for name, item in CATALOGUE.items() if getattr(item, self._field))

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def __repr__(self) -> str:
        return f"entry_text({self._field!r}: {list(self)})"


def entry_text(field: str) -> Mapping[str, str]:
    """One text field (``rig_check``, ``label``, ``cause``) of the library's entries, by name.

    Only the entries that set it, in catalogue order, as the catalogue is when read.

    Raises:
        EffectError: ``field`` is no text field of an entry.
    """
    if field not in {"rig_check", "label", "cause"}:
        raise EffectError(f"entry_text: {field!r} is not a text field of an effect entry")
    return _EntryText(field)


def stand_ins() -> dict[str, tuple[str, ...]]:
    """Each calibrated value and the library effects whose misfit shows up in it.

    From every entry's ``stands_in_for``, the effects in catalogue order.
    """
    found: dict[str, tuple[str, ...]] = {}
    for item in CATALOGUE.values():
        for value in item.stands_in_for:
            found[value] = (*found.get(value, ()), item.name)
    return found


_Item = TypeVar("_Item")


class _InCatalogueOrder(Mapping[str, _Item]):
    """A registry's items of one part of the catalogue, in its order (a live view)."""

    def __init__(self, entries: Mapping[str, EffectEntry], items: Mapping[str, _Item]) -> None:
        self._entries = entries
        self._items = items

    def __getitem__(self, name: str) -> _Item:
        if name not in self._entries:
            raise KeyError(name)
        return self._items[name]

    def __iter__(self) -> Iterator[str]:
        return (name for name in self._entries if name in self._items)

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({list(self)})"


class EntryRegistry(Generic[_Item]):
    """What points to the catalogue's entries (a truth law, a candidate), one per effect.

    Read through :meth:`view`, in the catalogue's order whatever the order of registration,
    so what draws from it (a case schedule, a diagnosis) is the same on every run.
    """

    def __init__(self, kind: str) -> None:
        self.kind = kind  # what one item is, in messages: "a truth law", "a candidate"
        self._items: dict[str, _Item] = {}

    def add(self, name: str, item: _Item) -> None:
        """Register ``item`` for the effect ``name``.

        Raises:
            EffectError: that effect has one already.
        """
        if name in self._items:
            held = self._items[name]
            shown = getattr(held, "__name__", type(held).__name__)
            raise EffectError(f"effect {name} has {self.kind} already ({shown})")
        self._items[name] = item

    def remove(self, name: str) -> None:
        """Take out the item of ``name`` (nothing when there is none)."""
        self._items.pop(name, None)

    def get(self, name: str) -> _Item | None:
        """The item of ``name``, or None."""
        return self._items.get(name)

    def view(self, entries: Mapping[str, EffectEntry] | None = None) -> Mapping[str, _Item]:
        """The items of ``entries`` (default: the library), in their order, as they are read."""
        return _InCatalogueOrder(CATALOGUE if entries is None else entries, self._items)


def effect_names() -> tuple[str, ...]:
    """The library's effect names, in catalogue order."""
    return tuple(CATALOGUE)


def entry(name: str) -> EffectEntry:
    """The entry of ``name``, in or out of the library.

    Raises:
        EffectError: no such effect.
    """
    for catalogue in (CATALOGUE, OUT_OF_LIBRARY):
        if name in catalogue:
            return catalogue[name]
    known = ", ".join([*CATALOGUE, *OUT_OF_LIBRARY])
    raise EffectError(f"unknown effect {name!r} (known: {known})")


def register(item: EffectEntry, *, in_library: bool = True) -> EffectEntry:
    """Add an effect made at run time (a plug-in, a test) to the catalogue.

    Raises:
        EffectError: an effect of that name is already there.
    """
    if item.name in CATALOGUE or item.name in OUT_OF_LIBRARY:
        raise EffectError(f"effect {item.name} is already in the catalogue")
    (CATALOGUE if in_library else OUT_OF_LIBRARY).add(item)
    return item


def unregister(name: str) -> None:
    """Remove an effect added by :func:`register` (nothing when absent)."""
    CATALOGUE.remove(name)
    OUT_OF_LIBRARY.remove(name)
