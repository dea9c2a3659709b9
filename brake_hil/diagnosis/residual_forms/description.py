"""The description of the baseline's misfit (:class:`ResidualDescription`) and its words."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

from brake_hil.diagnosis.residual_forms.fitting import FormFit
from brake_hil.diagnosis.residual_forms.misfit import ChannelMisfit

__all__ = ["NOISE_EXCESS", "STANDS_OUT_RATIO", "ResidualDescription", "summarise", "times_noise"]

STANDS_OUT_RATIO = 1.5
"""A form stands out when it cuts the held-out error at least this many times (the
diagnosis's ``CLEAR_ACCEPT_RATIO``) ..."""
NOISE_EXCESS = 4.0
"""... and the baseline's held-out error is at least this many times the noise's share."""


@dataclass(frozen=True)
class ResidualDescription:
    """What the baseline's misfit looks like and the generic forms that describe it.

    The flags are those of ``channel``, the channel that carries most of the held-out error;
    ``channels`` holds every channel's. ``forms`` are ranked by held-out improvement (all
    channels); ``best`` is the first when it stands out (cuts the held-out error
    ``STANDS_OUT_RATIO`` times while the misfit is ``NOISE_EXCESS`` times the noise), else None.
    """

    channel: str
    channels: tuple[ChannelMisfit, ...]
    forms: tuple[FormFit, ...]
    best: FormFit | None
    baseline_cost: float  # mean over channels of the held-out normalised mean squared error
    noise_cost: float | None  # the noise's share of it (Dataset.noise_cost), when known
    summary: str

    def misfit(self, channel: str | None = None) -> ChannelMisfit:
        """The description of ``channel`` (default: the one carrying most of the misfit)."""
        key = self.channel if channel is None else channel
        return next(c for c in self.channels if c.channel == key)

    @property
    def shares(self) -> dict[str, float]:
        """Each channel's share of the baseline's held-out error (normalised, sums to 1)."""
        return {c.channel: c.share for c in self.channels}

    @property
    def static(self) -> bool:
        """A static map of the prediction explains most of the misfit."""
        return self.misfit().static

    @property
    def dynamic(self) -> bool:
        """The misfit depends on the prediction's rate more than on its value."""
        return self.misfit().dynamic

    @property
    def symmetric(self) -> bool:
        """Apply and release carry the same misfit."""
        return self.misfit().symmetric

    @property
    def level_dependent(self) -> bool:
        """The misfit changes monotonically with the pressure level."""
        return self.misfit().level_dependent

    @property
    def grows_with_pressure(self) -> bool:
        """The misfit changes with the level and is largest at the highest level."""
        return self.misfit().grows_with_pressure

    @property
    def drifts(self) -> bool:
        """The misfit drifts in time within the segments."""
        return self.misfit().drifts

    def reworded(self, verdict: str) -> ResidualDescription:
        """The same description, its summary starting with ``verdict``.

        On a diagnosis whose verdict names an effect (or none), the misfit described is the
        calibrated baseline's, not an ``unexplained`` one.
        """
        excess = times_noise(self.baseline_cost, self.noise_cost, self.forms)
        summary = summarise(verdict, self.misfit(), self.forms, self.best, excess)
        return replace(self, summary=summary)

    def verdict_entry(self) -> dict[str, object] | None:
        """``verdict.unexplained_form`` of docs/interface.md (None when nothing stands out)."""
        if self.best is None:
            return None
        return {
            "description": self.best.description,
            "form": self.best.form,
            "channel": self.best.channel,
            "improvement": round(self.best.improvement, 3),
        }

    def as_dict(self) -> dict[str, object]:
        """Plain JSON for ``diagnosis.json``."""
        return {
            "summary": self.summary,
            "channel": self.channel,
            "shares": {k: round(v, 4) for k, v in self.shares.items()},
            "flags": {
                "static": self.static,
                "dynamic": self.dynamic,
                "symmetric": self.symmetric,
                "level_dependent": self.level_dependent,
                "grows_with_pressure": self.grows_with_pressure,
                "drifts": self.drifts,
            },
            "channels": {c.channel: c.as_dict() for c in self.channels},
            "best": None if self.best is None else self.best.as_dict(),
            "forms": [f.as_dict() for f in self.forms],
            "baseline_cost": self.baseline_cost,
            "noise_cost": self.noise_cost,
        }


def _character_words(misfit: ChannelMisfit) -> list[str]:
    """The flags in words."""
    words = []
    if misfit.static:
        words.append("static")
    elif misfit.dynamic:
        words.append("rate-dependent")
    if misfit.level_dependent:
        words.append(
            "growing with pressure" if misfit.level_trend > 0 else "falling with pressure"
        )
    else:
        words.append("not changing with pressure")
    if misfit.symmetric:
        words.append("symmetric")
    else:
        larger = "apply" if misfit.asymmetry > 0 else "release"
        words.append(f"asymmetric (larger on {larger})")
    if misfit.drifts:
        words.append("drifting")
    return words


def times_noise(
    baseline_cost: float, noise_cost: float | None, ranked: Sequence[FormFit]
) -> float | None:
    """The baseline's held-out error over the noise's share (None when the noise is unknown).

    No form fitted on training predicts held-out noise, so the noise's share is at most what
    the best form left.
    """
    floor = noise_cost
    if floor is not None and ranked:
        floor = min(floor, baseline_cost / max(ranked[0].improvement, 1.0))
    return None if floor is None else baseline_cost / max(floor, 1e-300)


def summarise(
    verdict: str,
    misfit: ChannelMisfit,
    forms: Sequence[FormFit],
    best: FormFit | None,
    excess: float | None,
) -> str:
    """The one sentence of :attr:`ResidualDescription.summary`."""
    carried = f"carried by {misfit.channel} ({100 * misfit.share:.0f} % of the held-out error)"
    character = ", ".join([carried, *_character_words(misfit)])
    if best is not None:
        return (
            f"{verdict}; looks like {best.description}, {character}; that form cuts the "
            f"held-out error {best.improvement:.1f} times"
        )
    if excess is not None and excess < NOISE_EXCESS:
        reason = (
            f"the baseline's held-out error is only {excess:.1f} times the measurement noise's "
            "share"
        )
    else:
        top = forms[0]
        reason = (
            f"no generic form cuts the held-out error {STANDS_OUT_RATIO:g} times (best: "
            f"{top.phrase} of {top.channel}, {top.improvement:.2f} times)"
        )
    return f"{verdict}; nothing stands out: {reason}; the misfit is {character}"
