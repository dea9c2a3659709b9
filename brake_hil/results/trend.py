"""A rig's health over time: its calibrated values and effects across diagnoses, in words.

From the stored diagnoses of one rig (:meth:`~brake_hil.results.store.ResultsStore.diagnoses`,
in time order) each calibrated value becomes a series of multipliers over the rig file's
value (1 = nominal, tolerance band ``exp(±sigma)`` of the rig file's log-sigma) and each
effect a series of its strength, the log10 of its hypothesis's held-out improvement (how many
times the effect cuts the held-out error), with whether the verdict named it. Each series gets
a robust trend over the run number (Theil-Sen, :func:`scipy.stats.theilslopes`) and, only when
the data show one beyond doubt, one line in plain words:

* **drift**: the value moved by at least :data:`MIN_CHANGE` of its tolerance along the fitted
  line, and the move is significant (the Mann-Kendall test, widened for day-to-day
  correlation, below :data:`SIGNIFICANCE`, and Theil-Sen's :data:`CONFIDENCE` interval of the
  slope excluding 0): ``caliper stiffness fell 12 % over 40 runs (tolerance ±25 %): check the
  caliper mounting``;
* **offset**: no drift, and at least :data:`OFFSET_SHARE` of the runs outside the band on one
  side: ``needle-valve resistance sits 60 % above the rig file in every run (tolerance
  ±40 %): update the rig file``; unless the verdicts named, in most runs, an effect the LTI
  model's value stands in for (:data:`STANDS_IN_FOR`: the seal's ``k_eh`` for stick-slip
  friction, ...): then the line says so, and that the rig file is not what is wrong;
* **grew**: an effect's strength rose by at least :data:`MIN_GROWTH` (log10) along a
  significant trend, and the verdict named it in at least :data:`NAMED_SHARE` of the last
  third of the runs: ``seal stick-slip grew over 30 runs (...): seal wear``.

* **outside**: whatever the number of runs, a run whose value sits at least
  :data:`OUTSIDE_SIGMA` tolerances from the rig file's is said at once: ``run 5: seal
  stiffness k_eh at 0.12 of the rig file's value, outside its tolerance ±50 % (4.3 times
  it)``.

Only runs that identify a value (posterior sigma under the calibration's own
:data:`~brake_hil.diagnosis.physics_checks.IDENTIFIABLE_SHARE` of the prior) count for it.
The trend test cannot fire on fewer than :data:`TREND_RUNS` runs (a perfectly monotone
series of fewer stays above :data:`SIGNIFICANCE`): such a series is "too few runs to test a
trend", never steady; an offset needs :data:`MIN_RUNS`. Multipliers are relative to the rig
file, so only the runs of the rig file's latest version are compared.

The thresholds were set on synthetic fleets (``test/results/fleets.py``): steady rigs
(offsets within the band, heavy-tailed and day-to-day correlated scatter up to a third of
the tolerance, steady effects named or not) got a line in 13 of 2000 fleets of 30 runs
(0.65 %; 1.1 % with the *outside* rule, which alone spoke on 0.45 %: docs/benchmarks.md),
while in each of 200 wearing rigs of 40 runs the 12 % fall of caliper stiffness
(2 % scatter), the air fraction rising 4 times and the growing seal stick-slip were found.
With 4 % scatter a 12 % fall is found in 88 % of 40-run fleets, 48 % of 20-run ones.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
import math
from typing import Any, Final

import numpy as np

from brake_hil.diagnosis.physics_checks import IDENTIFIABLE_SHARE
from brake_hil.diagnosis.rig_findings import AIR_VALUES, air_in_words
from brake_hil.physics.catalogue import stand_ins
from brake_hil.results.store import DiagnosisRow
from brake_hil.results.trend_series import ADVICE, Advice, Movement, Series
from brake_hil.results.trend_series import advice as _advice
from brake_hil.results.trend_statistics import (
    CONFIDENCE,
    SIGNIFICANCE,
    TREND_RUNS,
    _Fit,
    _fit,
    _no_fit,
)
from brake_hil.types import BoolArray, FloatArray, IntArray
from brake_hil.words import counted

__all__ = [
    "ADVICE",
    "STANDS_IN_FOR",
    "CONFIDENCE",
    "MIN_CHANGE",
    "MIN_GROWTH",
    "MIN_RUNS",
    "NAMED_SHARE",
    "OFFSET_SHARE",
    "OUTSIDE_SIGMA",
    "SIGNIFICANCE",
    "TREND_RUNS",
    "Advice",
    "Movement",
    "RigTrend",
    "Series",
    "identified",
    "rig_trend",
    "trends",
]

MIN_RUNS: Final = 5
"""Fewest runs (identifying a value) an offset from the rig file needs."""
MIN_CHANGE: Final = 1.0 / 3.0
"""Smallest move of a value along its fitted line, as a share of its tolerance (log-sigma),
called a drift (1/3 of 25 %: 8 % of caliper stiffness)."""
OFFSET_SHARE: Final = 0.9
"""Share of runs outside the band, all on one side, that makes an offset from the rig file."""
MIN_GROWTH: Final = math.log10(2.0)
"""Smallest rise of an effect's strength along its fitted line (log10: it cuts the held-out
error twice as much as it did)."""
NAMED_SHARE: Final = 1.0 / 3.0
"""Share of the last third of the runs whose verdict must name a growing effect."""
OUTSIDE_SIGMA: Final = 3.0
"""A run whose value sits this many tolerances (log-sigmas) from the rig file's is said at
once, whatever the number of runs (the diagnosis report's ``FLAG_SIGMA``: the rig file's value
is then itself a finding). Its false-alarm rate on steady fleets is in docs/benchmarks.md."""


class _StandsInFor(Mapping[str, tuple[str, ...]]):
    """Each calibrated value and the effects standing in it, from the entries (live)."""

    def __getitem__(self, name: str) -> tuple[str, ...]:
        return stand_ins()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(stand_ins())

    def __len__(self) -> int:
        return len(stand_ins())


STANDS_IN_FOR: Final[Mapping[str, tuple[str, ...]]] = _StandsInFor()
"""Calibrated LTI values and the effects whose misfit the calibration puts into them (each
entry's ``stands_in_for``, the effects in catalogue order)."""


@dataclass(frozen=True)
class RigTrend:
    """Every series of one rig, and which runs they came from."""

    rig: str  # the rig's name
    rows: tuple[DiagnosisRow, ...]  # the diagnoses trended (latest rig file), time order
    series: tuple[Series, ...]
    earlier: int = 0  # diagnoses against earlier versions of the rig file, left out
    notes: tuple[str, ...] = field(default=())

    @property
    def findings(self) -> tuple[str, ...]:
        """The lines in plain words: drifts first, then offsets, then growing effects."""
        order = {Movement.OUTSIDE: 0, Movement.DRIFT: 1, Movement.GREW: 2, Movement.OFFSET: 3}
        found = sorted(
            (s for s in self.series if s.finding is not None), key=lambda s: order[s.movement]
        )
        return tuple(s.finding for s in found if s.finding is not None)

    @property
    def too_few(self) -> tuple[Series, ...]:
        """Series with fewer than :data:`TREND_RUNS` usable runs."""
        return tuple(s for s in self.series if s.movement is Movement.TOO_FEW)

    def summary(self) -> list[str]:
        """What to print: the findings, or what no line means; what was not judged."""
        runs = len(self.rows)
        lines = list(self.findings)
        if runs < TREND_RUNS:
            lines.append(f"{counted(runs, 'run')}: too few to test a trend; {TREND_RUNS} needed")
        elif not lines:
            lines.append(_nothing_found(self.series, runs))
        carried = {s.name for s in self.series if s.modelled and s.finding}
        few = [s for s in self.too_few if s.kind == "value" and s.name not in carried]
        if runs >= TREND_RUNS and few:
            names = ", ".join(f"{s.words} ({int(s.used.sum())})" for s in few)
            lines.append(f"identified in too few runs to test a trend: {names}")
        named = [
            s
            for s in self.series
            if s.kind == "effect" and s.finding is None and s.named.sum() > s.named.size / 2
        ]
        if named:
            names = ", ".join(f"{s.words} ({int(s.named.sum())} of {s.named.size})" for s in named)
            lines.append(f"named in most runs, without a trend: {names}")
        return lines + list(self.notes)


def _nothing_found(series: Sequence[Series], runs: int) -> str:
    """No line: that nothing left its band, or which values did, within their scatter."""
    left = []
    for s in series:
        if s.kind != "value" or s.band is None:
            continue
        shown = s.values[s.used]
        out = int(((shown < s.band[0]) | (shown > s.band[1])).sum())
        if out:
            left.append(f"{s.words} ({out} of {shown.size})")
    if not left:
        return f"no value or effect left its band over {runs} runs"
    return (
        f"no drift, offset or growth beyond doubt over {runs} runs; outside the band in some "
        f"runs, without a trend: {', '.join(left)}"
    )


def identified(prior_sigma: float, posterior_sigma: float) -> bool:
    """Whether a run identifies a value: the calibration's own rule (``not_identified``)."""
    return math.isfinite(posterior_sigma) and posterior_sigma <= IDENTIFIABLE_SHARE * prior_sigma


def trends(rows: Iterable[DiagnosisRow]) -> list[RigTrend]:
    """One :class:`RigTrend` per rig name, sorted by name; rows in time order."""
    by_rig: dict[str, list[DiagnosisRow]] = {}
    for row in rows:
        by_rig.setdefault(row.rig_name, []).append(row)
    return [rig_trend(by_rig[name]) for name in sorted(by_rig)]


def rig_trend(rows: Sequence[DiagnosisRow]) -> RigTrend:
    """The series of one rig's diagnoses (in time order), against its latest rig file."""
    if not rows:
        raise ValueError("no diagnosis to trend")
    latest = rows[-1].rig_hash
    kept = tuple(r for r in rows if r.rig_hash == latest)
    earlier = len(rows) - len(kept)
    notes: tuple[str, ...] = ()
    if earlier:
        notes = (
            f"{earlier} earlier diagnoses used another version of the rig file "
            f"(multipliers are relative to it): left out, {len(kept)} trended",
        )
    values = list(dict.fromkeys(c.name for r in kept for c in r.calibration))
    effects = list(
        dict.fromkeys(h.effect for r in kept for h in r.hypotheses if "+" not in h.effect)
    )
    named = {e: sum(e in r.effects for r in kept) for r in kept for e in r.effects}
    series = [_value_series(name, kept, named) for name in values]
    series += _carried_series(series, kept, named)
    series += [_effect_series(name, kept) for name in effects]
    return RigTrend(kept[0].rig_name, kept, tuple(_air_said(series, kept)), earlier, notes)


def _air_said(series: list[Series], rows: Sequence[DiagnosisRow]) -> list[Series]:
    """An air finding says which air it is (the rig file's own or more), as last said."""
    said = next(filter(None, (air_in_words(r.explanation) for r in reversed(rows))), None)
    out = []
    for item in series:
        cause = _advice(item.name).cause
        if said and item.name in AIR_VALUES and item.finding and item.finding.endswith(cause):
            item = replace(item, finding=f"{item.finding[: -len(cause)]}{said}")
        out.append(item)
    return out


def _carried_series(
    lti: Sequence[Series], rows: Sequence[DiagnosisRow], named: Mapping[str, int]
) -> list[Series]:
    """The air's values as the improved model holds them, each with its drift (or none).

    Beside a named effect the LTI calibration rarely identifies the air fraction (the
    effect's misfit dwarfs the air's), while the improved model, with that effect modelled,
    refits it in every run: air collecting beside a wearing seal shows there first. Only
    the air's values, and only where their LTI series says nothing: the other values the
    improved model refits trade with the air (a hose wall stiffens as the air's compliance,
    which follows the pressure, grows), so a drift of theirs is not the rig's.
    """
    effect, count = max(named.items(), key=lambda kv: kv[1], default=(None, 0))
    if effect is None or count <= len(rows) / 2:
        return []
    found = []
    for item in lti:
        if item.name not in AIR_VALUES or item.finding is not None or item.band is None:
            continue
        runs, values = [], []
        for index, row in enumerate(rows):
            value = next((c for c in row.calibration if c.name == item.name), None)
            if value is not None and (value.improved_multiplier or 0.0) > 0.0:
                runs.append(index)
                values.append(float(value.improved_multiplier or 1.0))
        if len(values) < TREND_RUNS:
            continue
        x, y, sigma = np.array(runs, dtype=np.int64), np.log(values), -math.log(item.band[0])
        fit = _fit(x.astype(float), y)
        movement, finding = Movement.STEADY, None
        if fit.significant and abs(fit.last - fit.first) >= MIN_CHANGE * sigma:
            words = _advice(item.name)
            movement, finding = (
                Movement.DRIFT,
                (
                    f"with the {_advice(effect).words} modelled, {words.words} "
                    f"{_moved(fit.last - fit.first)} over {len(values)} runs (tolerance "
                    f"±{100 * sigma:.0f} %): {words.cause}"
                ),
            )
        found.append(
            replace(
                item,
                runs=x,
                times_ns=_times(rows, runs),
                values=np.exp(y),
                used=np.ones(x.shape, dtype=bool),
                named=np.zeros(x.shape, dtype=bool),
                **_line(fit),
                movement=movement,
                finding=finding,
                outside=(),
                stand_in=False,
                modelled=effect,
            )
        )
    return found


def _line(fit: _Fit) -> dict[str, Any]:
    """A series' fitted trend line (its slope, interval, intercept and test), as fields."""
    return {
        "slope": fit.slope,
        "interval": fit.interval,
        "intercept": fit.intercept,
        "p_value": fit.p_value,
    }


def _times(rows: Sequence[DiagnosisRow], runs: list[int]) -> IntArray:
    stamps = [rows[i].start_ns for i in runs]
    return np.array([-1 if s is None else s for s in stamps], dtype=np.int64)


def _value_series(
    name: str, rows: Sequence[DiagnosisRow], named: Mapping[str, int] | None = None
) -> Series:
    """One calibrated value's series; ``named``: how many runs named each effect."""
    runs: list[int] = []
    values: list[float] = []
    used: list[bool] = []
    sigma = math.nan
    for index, row in enumerate(rows):
        value = next((c for c in row.calibration if c.name == name), None)
        if value is None:
            continue
        runs.append(index)
        values.append(value.multiplier)
        used.append(identified(value.prior_sigma, value.posterior_sigma))
        sigma = value.prior_sigma  # one rig file: one tolerance
    mask = np.array(used, dtype=bool)
    run_numbers = np.array(runs, dtype=np.int64)
    multipliers = np.array(values, dtype=float)
    band = (math.exp(-sigma), math.exp(sigma))
    movement, finding, fit = Movement.TOO_FEW, None, _no_fit()
    stands_in = _stood_in_for(name, rows, named)
    y = np.log(multipliers[mask])
    stood_in = None if stands_in else _back_within(name, rows, sigma, named)
    if mask.sum() >= MIN_RUNS:
        fit = _fit(run_numbers[mask].astype(float), y) if mask.sum() >= TREND_RUNS else fit
        movement, finding = _judge_value(name, y, sigma, fit, stands_in)
        if movement is Movement.STEADY and mask.sum() < TREND_RUNS:
            movement = Movement.TOO_FEW
    outside = tuple(int(r) for r in run_numbers[mask][np.abs(y) >= OUTSIDE_SIGMA * sigma])
    if outside and movement in (Movement.STEADY, Movement.TOO_FEW):
        movement = Movement.OUTSIDE
        last = float(multipliers[run_numbers == outside[-1]][0])
        finding = _outside(name, outside, last, sigma, stands_in)
    if finding is not None and stood_in is not None:
        finding = f"{finding.rsplit(': ', 1)[0]}: {stood_in}"
    return Series(
        name=name,
        kind="value",
        runs=run_numbers,
        times_ns=_times(rows, runs),
        values=multipliers,
        used=mask,
        named=np.zeros(mask.shape, dtype=bool),
        band=band,
        **_line(fit),
        movement=movement,
        finding=finding,
        outside=outside,
        stand_in=finding is not None and stood_in is not None,
    )


def _outside(
    name: str, runs: Sequence[int], multiplier: float, sigma: float, stands_in: str | None
) -> str:
    """``run 5: seal stiffness at 0.12 of the rig file's value, outside ... : cause``."""
    advice = _advice(name)
    times = abs(math.log(multiplier)) / sigma
    also = ""
    if len(runs) > 1:
        earlier = ", ".join(str(r + 1) for r in runs[:-1])
        also = f"; also in run{'s' if len(runs) > 2 else ''} {earlier}"
    if stands_in is not None:
        also += f"; the LTI model also stands in with it for the {stands_in}"
    return (
        f"run {runs[-1] + 1}: {advice.words} at {multiplier:.2g} of the rig file's value, "
        f"outside its tolerance ±{100 * sigma:.0f} % ({times:.1f} times it{also}): "
        f"{advice.cause}"
    )


def _back_within(
    name: str, rows: Sequence[DiagnosisRow], sigma: float, named: Mapping[str, int] | None
) -> str | None:
    """Why a value's move is the LTI model's alone, in words, or None.

    The calibrated LTI model may move a value to stand in for the physics it lacks beyond
    the catalogue's ``stands_in_for`` (the caliper's stiffness and force area lowered
    together beside a stick-slip seal). When the improved model, with the effect named in
    most runs modelled, holds the value within its tolerance in most runs, its move is that
    stand-in, not the rig's.
    """
    common = max((named or {}).items(), key=lambda kv: kv[1], default=(None, 0))
    effect, count = common
    if effect is None or count <= len(rows) / 2:
        return None
    improved = [
        v.improved_multiplier
        for row in rows
        for v in row.calibration
        if v.name == name and v.improved_multiplier is not None
    ]
    within = sum(abs(math.log(m)) <= sigma for m in improved if m > 0.0)
    if not improved or within <= len(improved) / 2:
        return None
    return (
        f"within its tolerance in {within} of {len(improved)} runs once the "
        f"{_advice(effect).words} is modelled: the LTI model's stand-in for it, not the rig"
    )


def _stood_in_for(
    name: str, rows: Sequence[DiagnosisRow], named: Mapping[str, int] | None
) -> str | None:
    """The effect the value stands in for, named in most of ``rows``, in words with its count."""
    for effect in STANDS_IN_FOR.get(name, ()):
        count = (named or {}).get(effect, 0)
        if count > len(rows) / 2:
            return f"{_advice(effect).words} named in {count} of {len(rows)} runs"
    return None


def _judge_value(
    name: str, logs: FloatArray, sigma: float, fit: _Fit, stands_in: str | None = None
) -> tuple[Movement, str | None]:
    """Drift, offset or steady, and the line in words (module docstring).

    ``stands_in``: an effect the value stands in for, named in most runs (an offset is then
    the LTI model's stand-in for it, not a rig-file error).
    """
    advice = _advice(name)
    count = logs.size
    tolerance = f"tolerance ±{100 * sigma:.0f} %"
    change = fit.last - fit.first
    if fit.significant and abs(change) >= MIN_CHANGE * sigma:
        outside = abs(fit.last) > sigma
        where = (
            f"{tolerance}, now {'above' if fit.last > 0 else 'below'} it" if outside else tolerance
        )
        return Movement.DRIFT, (
            f"{advice.words} {_moved(change)} over {count} runs ({where}): {advice.cause}"
        )
    above, below = int((logs > sigma).sum()), int((logs < -sigma).sum())
    if (off := max(above, below)) >= OFFSET_SHARE * count:
        runs = "every run" if off == count else f"{off} of {count} runs"
        cause = (
            f"the calibrated LTI model stands in with it for the {stands_in}, not a rig-file error"
            if stands_in is not None
            else "update the rig file"
        )
        return Movement.OFFSET, (
            f"{advice.words} sits {_offset(float(np.median(logs)))} in {runs} ({tolerance}): "
            f"{cause}"
        )
    return Movement.STEADY, None


def _moved(log_change: float) -> str:
    """A move of a log multiplier in words: ``fell 12 %``, ``rose 3.4 times``."""
    factor = math.exp(log_change)
    if factor >= 2.0:
        return f"rose {factor:.1f} times"
    if factor <= 0.5:
        return f"fell to {factor:.2g} of its first value"
    return f"{'rose' if factor > 1 else 'fell'} {100 * abs(factor - 1.0):.0f} %"


def _offset(log_level: float) -> str:
    """Where a log multiplier sits: ``60 % above the rig file`` or ``at 0.2 of its value``."""
    factor = math.exp(log_level)
    if factor >= 2.0 or factor <= 0.5:
        return f"at {factor:.2g} times the rig file's value"
    return f"{100 * abs(factor - 1.0):.0f} % {'above' if factor > 1 else 'below'} the rig file"


def _effect_series(name: str, rows: Sequence[DiagnosisRow]) -> Series:
    runs: list[int] = []
    strengths: list[float] = []
    named: list[bool] = []
    for index, row in enumerate(rows):
        hypothesis = next((h for h in row.hypotheses if h.effect == name), None)
        if hypothesis is None:
            continue  # not fitted in that run
        runs.append(index)
        strengths.append(math.log10(hypothesis.held_out_improvement))
        named.append(name in row.effects)
    run_numbers = np.array(runs, dtype=np.int64)
    values = np.array(strengths, dtype=float)
    named_mask = np.array(named, dtype=bool)
    used = np.ones(values.shape, dtype=bool)
    movement, finding, fit = Movement.TOO_FEW, None, _no_fit()
    if values.size >= TREND_RUNS:
        fit = _fit(run_numbers.astype(float), values)
        movement, finding = _judge_effect(name, values, named_mask, fit)
    return Series(
        name=name,
        kind="effect",
        runs=run_numbers,
        times_ns=_times(rows, runs),
        values=values,
        used=used,
        named=named_mask,
        band=None,
        **_line(fit),
        movement=movement,
        finding=finding,
    )


def _judge_effect(
    name: str, strengths: FloatArray, named: BoolArray, fit: _Fit
) -> tuple[Movement, str | None]:
    """Grew or steady (module docstring)."""
    last_third = named[-max(1, math.ceil(named.size / 3)) :]
    rise = fit.last - fit.first
    if (
        fit.significant
        and fit.slope > 0
        and rise >= MIN_GROWTH
        and last_third.sum() >= NAMED_SHARE * last_third.size
    ):
        advice = _advice(name)
        return Movement.GREW, (
            f"{advice.words} grew over {strengths.size} runs (it cuts the held-out error "
            f"{_times_text(fit.first)} -> {_times_text(fit.last)}; named in "
            f"{int(last_third.sum())} of the last {last_third.size}): {advice.cause}"
        )
    return Movement.STEADY, None


def _times_text(log10_improvement: float) -> str:
    factor = 10.0**log10_improvement
    return f"{factor:.0f}x" if factor >= 10 else f"{factor:.1f}x"
