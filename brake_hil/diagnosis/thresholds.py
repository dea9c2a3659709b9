"""The tuned thresholds of the diagnosis's verdict (:mod:`.verdict`), in one place.

Every threshold is a ratio of held-out mean squared errors (``Fit.held_out_cost``), a share
of the baseline's held-out error, or a decision margin in log units. What each guards and the
evidence behind its value: docs/diagnosis.md.
"""

from __future__ import annotations

ACCEPT_RATIO = 2.0
"""A hypothesis must cut the baseline's held-out mean squared error this many times.

Half the misfit or more explained by a physics is more than a stand-in fitting the residue
of a parameter error does. Evidence: docs/diagnosis.md.
"""
CLEAR_EXCESS = 10.0
"""Baseline held-out error over the noise's share above which ``CLEAR_ACCEPT_RATIO`` applies.

A misfit this far above the noise is clearly missing physics, so a smaller cut names it.
Evidence: docs/diagnosis.md.
"""
CLEAR_ACCEPT_RATIO = 1.5
"""The cut asked of a hypothesis when the misfit is clearly more than noise (``CLEAR_EXCESS``).

Evidence: docs/diagnosis.md.
"""
NOISE_EXCESS = 8.0
"""Baseline held-out error over the noise's share under which no effect is named.

Within a few noise variances what is left is the residue of a parameter error, which a
candidate can halve; only a weak single that explains it all is named (``WEAK_SINGLE_RATIO``).
Evidence: docs/diagnosis.md.
"""
WEAK_SINGLE_RATIO = 3.0
"""Under ``NOISE_EXCESS``, the cut a single effect must reach alone to be named.

A parameter error's residue is cut about twice at most by any candidate; a weak real effect's
own candidate cuts it more. Evidence: docs/diagnosis.md.
"""
WEAK_SINGLE_LEFT = 2.5
"""Under ``NOISE_EXCESS``, the most a named weak single may leave, in noise shares.

It must explain all but the noise. Evidence: docs/diagnosis.md.
"""
PAIR_RATIO = 1.8
"""A second effect must cut the error of the better of its singles again this many times.

A second physics must earn its place against the first alone. Evidence: docs/diagnosis.md.
"""
PAIR_SHARE = 0.03
"""... and explain at least this share of the baseline's held-out error more than that single.

Evidence: docs/diagnosis.md.
"""
WINDOW_FLOOR = 0.5
"""No held-out window may get worse than this times the baseline's error (0: no test).

Missing physics is missing in every window; a stand-in for a parameter error helps one
segment and hurts another. Evidence: docs/diagnosis.md.
"""
PARAMETER_PENALTY = 0.05
"""Log-gain charged per fitted parameter when ranking hypotheses.

Of two hypotheses that explain the misfit equally, the simpler is kept.
Evidence: docs/diagnosis.md.
"""
UNEXPLAINED_RMS = 0.005
"""Held-out RMS of the baseline above which a misfit no candidate explains is 'unexplained'.

The worst channel's RMS residual over its peak-to-peak in the whole dataset.

A calibrated baseline with a parameter error only misses by about 0.1 % (noise and the
virtual rig's richer line); this is five times that. Evidence: docs/diagnosis.md.
"""
STRUCTURED_RATIO = 2.0
"""Cut by a generic form above which a small misfit is still 'unexplained'.

Half of it or more is then a structure no library effect explains, not noise and not a
parameter error (the calibration absorbs those). Evidence: docs/diagnosis.md.
"""
FORM_RATIO = 1.4
"""A library effect must cut the held-out error this many times more than a generic form.

The forms fit the baseline's residual freely; a real effect, with the calibration refitted
and its physics exact, beats them; one that does no better is not identified by its physics.
Evidence: docs/diagnosis.md.
"""
STAND_IN_MARGIN = 0.0
"""Decision margin (log units) a verdict keeps at most when its standing is in doubt.

When a better-scoring hypothesis failed a physics check, or the single named carries another
physics in its own values (``Candidate.not_alone``): the doubt is said in words
(``Verdict.capped``) and counted in the confidence (reliability.py). A single a pair betters
(``Summary.hidden_partner``) is charged that pair's log odds instead.
Evidence: docs/diagnosis.md.
"""
SIGNIFICANT_Z = 3.0
"""Standard errors of their own scatter over the cycles beyond which even harmonics of the bore
pressure that a model does not make are there (``evidence.even_harmonics_z``; a chance excess
this large is rarer than 1 in 700): a statistical bound, not tuned."""
CHECK_ROUNDS = 3
"""Verdicts checked at most: a verdict that fails a physics check is set aside, the next checked.
"""
PAIR_SHORTLIST = 8
"""Singles paired with the best single (the next best plausible ones, by score)."""
PAIR_FIT_RATIO = 1.3
"""Pairs are fitted when the best single cuts the held-out error at least this much."""
EFFECTIVE_SAMPLES = 25.0
"""Effectively independent held-out samples of a recording, for the posterior (posterior.py).

The held-out residuals are correlated over a 5 Hz cycle and across the three channels, so a
recording's thousands of held-out samples weigh as a few tens. Fitted to the log-loss of
right/wrong verdicts on a family-a set (docs/diagnosis.md); the posterior now ranks the
runner-up and weighs a pair against its single, and the confidence is reliability.py's.
"""
PARAMETER_CHARGE = 2.3
"""The Occam factor of one fitted parameter in the posterior (log units; posterior.py).

Laplace's approximation: the log of a parameter's prior width over the width the recording
pins it to. A candidate's parameter is searched over about a decade or two and a recording
fixes it to a tenth of that range or better: log(10) (docs/diagnosis.md).
"""
FORM_PARAMETERS = 4
"""Parameters charged to the best generic form of the misfit (``unexplained``'s hypothesis).

The generic forms fit one to four free values to a channel's residual; the most is charged,
as a candidate's law is charged all of its own.
"""
