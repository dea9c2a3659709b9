"""Fitting one form to one channel's training residual and scoring it on the held-out windows."""

from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np
import scipy.optimize

from brake_hil.diagnosis.residual_forms.base import ChannelSpans, FormParameter, ResidualForm
from brake_hil.types import FloatArray

__all__ = ["FormFit", "fit_form"]


@dataclass(frozen=True)
class FormFit:
    """One form fitted to one channel's training residual, scored on the held-out windows.

    Costs are mean squared residuals normalised by the channel's peak-to-peak (``scale``),
    as ``Fit.held_out_cost``; ``improvement`` is over all channels (the form on this channel,
    the baseline on the others), ``channel_improvement`` on this channel alone.
    """

    form: str
    channel: str
    phrase: str  # what the form is, in words
    detail: str  # its fitted values, read physically
    parameters: tuple[FormParameter, ...]  # fitted, SI
    constants: tuple[FormParameter, ...]  # fixed references, SI
    train_cost: float
    held_out_cost: float
    channel_improvement: float
    improvement: float

    @property
    def description(self) -> str:
        """The form in words: ``a static nonlinear map of F_k (cubic; ...)``."""
        detail = f" ({self.detail})" if self.detail else ""
        return f"{self.phrase} of {self.channel}{detail}"

    def as_dict(self) -> dict[str, object]:
        """Plain JSON."""
        return {
            "form": self.form,
            "channel": self.channel,
            "description": self.description,
            "parameters": {p.name: p.value for p in self.parameters},
            "units": {p.name: p.unit for p in (*self.parameters, *self.constants)},
            "constants": {p.name: p.value for p in self.constants},
            "train_cost": self.train_cost,
            "held_out_cost": self.held_out_cost,
            "channel_improvement": round(self.channel_improvement, 3),
            "held_out_improvement": round(self.improvement, 3),
        }


def fit_form(
    form: ResidualForm, train: ChannelSpans, held_out: ChannelSpans
) -> tuple[FloatArray, float, float]:
    """Fitted search-space parameters, training and held-out mean squared residual."""
    target = train.target

    def residual(x: FloatArray) -> FloatArray:
        return np.asarray(form.predict(x, train) - target, dtype=float)

    starts = form.starts()
    low, high = form.bounds(starts[0].size)
    costs = [float(np.mean(residual(np.clip(s, low, high)) ** 2)) for s in starts]
    x0 = np.clip(starts[int(np.argmin(np.nan_to_num(costs, nan=np.inf)))], low, high)
    design = form.jacobian(x0, train)
    with np.errstate(over="ignore", invalid="ignore"):
        if design is not None:
            fixed = design
            result = scipy.optimize.least_squares(
                residual, x0, jac=lambda x: fixed, method="lm", max_nfev=20
            )
        else:
            result = scipy.optimize.least_squares(
                residual, x0, bounds=(low, high), method="trf", x_scale="jac", max_nfev=60
            )
    x = np.asarray(result.x, dtype=float)
    train_cost = float(np.mean(residual(x) ** 2))
    held_out_cost = float(np.mean((form.predict(x, held_out) - held_out.target) ** 2))
    if not np.isfinite(held_out_cost):  # a form that cannot describe the data at all
        held_out_cost = math.inf
    return x, train_cost, held_out_cost
