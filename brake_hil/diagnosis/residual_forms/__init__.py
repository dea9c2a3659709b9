"""What an ``unexplained`` misfit looks like, and which generic physical form explains it best.

When no candidate of the library explains the calibrated LTI baseline's misfit, the verdict is
``unexplained``; this package says what that misfit is in physical terms (docs/interface.md:
``verdict.unexplained_form``). It takes the dataset and the baseline's predictions of every
output channel over the training and held-out windows, and

1. describes the misfit (:class:`ChannelMisfit`, one per channel): its share of the baseline's
   held-out error (normalised by ``Dataset.scale()``); static or rate-dependent (how much of it
   a static map ``y = f(y_hat)`` explains, and how much more terms in the rate ``dy_hat/dt``
   add); symmetric or not between apply (rising) and release (falling) halves; whether it
   changes with the pressure level (the three segments compared) and which way: it "grows
   with pressure" when the measured channel grows relative to the prediction as the level
   rises (the calibration centres such a misfit, so its size at each level cannot say it);
   whether it drifts in time;
2. fits the generic forms (``FORMS``, one module each behind :class:`ResidualForm`) to each
   channel's residual on the training windows with
   :func:`scipy.optimize.least_squares` and scores them on the held-out windows
   (improvement = the baseline's held-out mean squared error over that of baseline + form, per
   channel and over all channels, the measure ``Fit.held_out_cost`` takes);
3. returns a :class:`ResidualDescription`: the shares, the flags, the forms ranked by held-out
   improvement with their parameters and units, the best form, a one-sentence ``summary`` and
   :meth:`ResidualDescription.as_dict` for ``diagnosis.json``.

The forms, each of one channel (``y_hat`` predicted, ``y`` measured, SI units of the channel):

``static_map``
    ``y = y_hat + c0 + c1 y_hat + c2 y_hat^2 + c3 y_hat^3``: a transducer or a stiffness whose
    gain changes with its reading (cubic static nonlinearity).
``backlash``
    ``y = P_w[y_hat] + c0``, ``P_w`` the play (backlash) operator of width ``w``: the output
    stays put for ``w`` after each reversal (hysteresis, dead band on reversal; Krasnosel'skii
    and Pokrovskii, *Systems with Hysteresis*, 1989).
``level_gain``
    ``y = (1 + g0 + g1 (p_seg - p_ref)) y_hat + c0``: a gain that changes with the segment's
    mean master-cylinder pressure ``p_seg`` (amplitude-dependent stiffness or gain).
``fluid_loss``
    ``y = y_hat + c0 + k (V(t) - V_ref)``, ``V(t)`` the integral of the measured bore pressure
    from the recording's start (Pa s): fluid lost through a laminar leak ``Q = p_b / R_l``
    makes the channel drift in proportion to the volume lost.
``extra_lag``
    ``y = L_tau[y_hat] + c0``, ``L_tau`` a first-order lag ``tau y' + y = y_hat``.
``resonance``
    ``y = y_hat + g z + c0`` with ``z'' + 2 zeta omega z' + omega^2 z = -y_hat''``, a
    second-order mode (20-150 Hz) driven by the predicted signal's acceleration (base
    excitation; ``g = 1`` is the mode's full transmissibility).

Every form carries an offset ``c0``, so that no form wins by absorbing a constant misfit
alone. Stateful forms (play, lag, mode) are started from the window's own first period
repeated (the steady pulsing is periodic), so their start-up transient is outside the window.

A new form is a :class:`ResidualForm` subclass in its own module of this package,
decorated with :func:`register_form` and imported here; it then takes part in every
description (after the library's six, ``FORM_ORDER``).

Entry points: :func:`describe_residual` with the predictions of :func:`baseline_predictions`
(about 0.3-0.6 s for an 18 s recording: eighteen small fits). From
:func:`brake_hil.diagnosis.diagnose.diagnose`::

    predictions = baseline_predictions(baseline_model, baseline.theta)
    description = describe_residual(dataset, predictions, noise_cost=dataset.noise_cost())
    description.summary, description.as_dict(), description.verdict_entry()
"""

from __future__ import annotations

from brake_hil.diagnosis.residual_forms.backlash import Backlash, play
from brake_hil.diagnosis.residual_forms.base import (
    CHANNEL_UNITS,
    FORM_ORDER,
    MEGA,
    ChannelSpans,
    FormContext,
    FormParameter,
    LinearForm,
    ResidualForm,
    register_form,
    registered_forms,
)
from brake_hil.diagnosis.residual_forms.describe import (
    WindowSimulator,
    baseline_predictions,
    describe_residual,
)
from brake_hil.diagnosis.residual_forms.description import (
    NOISE_EXCESS,
    STANDS_OUT_RATIO,
    ResidualDescription,
)
from brake_hil.diagnosis.residual_forms.extra_lag import ExtraLag
from brake_hil.diagnosis.residual_forms.fitting import FormFit
from brake_hil.diagnosis.residual_forms.fluid_loss import FluidLoss
from brake_hil.diagnosis.residual_forms.level_gain import LevelGain
from brake_hil.diagnosis.residual_forms.misfit import (
    ASYMMETRY_LIMIT,
    DRIFT_SHARE,
    DRIFT_SIZE,
    LEVEL_VARIATION,
    RATE_SHARE,
    STATIC_SHARE,
    ChannelMisfit,
)
from brake_hil.diagnosis.residual_forms.resonance import Resonance
from brake_hil.diagnosis.residual_forms.static_map import StaticMap

__all__ = [
    "ASYMMETRY_LIMIT",
    "CHANNEL_UNITS",
    "DRIFT_SHARE",
    "DRIFT_SIZE",
    "FORMS",
    "FORM_ORDER",
    "LEVEL_VARIATION",
    "MEGA",
    "NOISE_EXCESS",
    "RATE_SHARE",
    "STANDS_OUT_RATIO",
    "STATIC_SHARE",
    "Backlash",
    "ChannelMisfit",
    "ChannelSpans",
    "ExtraLag",
    "FluidLoss",
    "FormContext",
    "FormFit",
    "FormParameter",
    "LevelGain",
    "LinearForm",
    "ResidualDescription",
    "ResidualForm",
    "Resonance",
    "StaticMap",
    "WindowSimulator",
    "baseline_predictions",
    "describe_residual",
    "play",
    "register_form",
    "registered_forms",
]

FORMS: tuple[ResidualForm, ...] = registered_forms()
"""The generic forms, in the order of the package docstring."""
