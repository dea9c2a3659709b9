"""Synthetic fleets of diagnoses: steady rigs and wearing ones, built from a real diagnosis.

A fleet is one rig's runs in time order. Each run's calibrated values and effect strengths
are drawn around a real diagnosis's (``diagnosis_one_washer_open.json`` beside this module:
``brake-hil diagnose bags/one_washer_open``; its prior sigmas, its nine single hypotheses).
Steady: every value at an offset within its band with heavy-tailed, day-to-day correlated
scatter, effects steady (named or not). Wearing: caliper stiffness falls 12 %, the air
fraction rises out of its band, seal stick-slip grows until it is named.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from brake_hil.results.store import CalibrationValue, DiagnosisRow, HypothesisRow

REAL_DIAGNOSIS = Path(__file__).with_name("diagnosis_one_washer_open.json")
"""``brake-hil diagnose bags/one_washer_open``'s ``diagnosis.json``, kept with the
tests: a fresh clone has no ``out/`` (the test that it is still what the command writes is in
``test_store.py``)."""
DAY_NS = 86_400 * 10**9
START_NS = 1_700_000_000 * 10**9


def real_document() -> dict[str, Any]:
    """A copy of the real diagnosis document."""
    return copy.deepcopy(json.loads(REAL_DIAGNOSIS.read_text()))


_DOCUMENT = real_document()
PRIOR_SIGMA: dict[str, float] = dict(_DOCUMENT["calibration"]["prior_sigma"])
SINGLES: tuple[str, ...] = tuple(h["effect"] for h in _DOCUMENT["hypotheses"])


@dataclass
class Run:
    """One synthetic diagnosis: log multipliers, identified values, log10 improvements."""

    logs: dict[str, float]
    identified: dict[str, bool]
    strengths: dict[str, float]
    named: list[str] = field(default_factory=list)
    improved: dict[str, float] = field(default_factory=dict)  # the improved model's logs


def _scatter(rng: np.random.Generator, runs: int, size: float) -> np.ndarray:
    """Heavy-tailed (Student t, 4 dof), day-to-day correlated (AR(1)) scatter of ``size``."""
    phi = rng.uniform(0.0, 0.5)
    shocks = rng.standard_t(4, runs) / math.sqrt(2.0)  # unit variance
    noise = np.empty(runs)
    noise[0] = shocks[0]
    for i in range(1, runs):
        noise[i] = phi * noise[i - 1] + math.sqrt(1 - phi**2) * shocks[i]
    return size * noise


def steady_fleet(rng: np.random.Generator, runs: int = 30) -> list[Run]:
    """A rig that does not change: values within their band, effects steady."""
    logs: dict[str, np.ndarray] = {}
    ident: dict[str, np.ndarray] = {}
    for name, sigma in PRIOR_SIGMA.items():
        offset = rng.uniform(-0.6, 0.6) * sigma
        logs[name] = offset + _scatter(rng, runs, rng.uniform(0.02, 0.33) * sigma)
        ident[name] = rng.random(runs) < rng.uniform(0.3, 1.0)
    present = set(rng.choice(SINGLES, size=int(rng.integers(0, 3)), replace=False))
    strengths: dict[str, np.ndarray] = {}
    for name in SINGLES:
        if name in present:
            level, size = rng.uniform(0.5, 2.5), rng.uniform(0.05, 0.3)
        else:
            level, size = rng.uniform(0.0, 0.15), rng.uniform(0.01, 0.08)
        strengths[name] = np.maximum(level + _scatter(rng, runs, size), -0.01)
    fleet = []
    for i in range(runs):
        named = [e for e in sorted(present) if rng.random() < 0.9][:1]
        fleet.append(
            Run(
                {n: float(v[i]) for n, v in logs.items()},
                {n: bool(v[i]) for n, v in ident.items()},
                {n: float(v[i]) for n, v in strengths.items()},
                named,
            )
        )
    return fleet


def wearing_fleet(rng: np.random.Generator, runs: int = 40) -> list[Run]:
    """Caliper stiffness falls 12 %, air fraction rises out of its band, seal stick-slip grows."""
    fleet = steady_fleet(rng, runs)
    ramp = np.linspace(0.0, 1.0, runs)
    caliper = math.log(0.88) * ramp + _scatter(rng, runs, 0.02)
    air = math.log(4.0) * ramp + _scatter(rng, runs, 0.1)
    seal = 0.2 + 1.8 * ramp + _scatter(rng, runs, 0.1)
    for i, run in enumerate(fleet):
        run.logs["caliper_stiffness"] = float(caliper[i])
        run.identified["caliper_stiffness"] = True
        run.logs["air_fraction"] = float(air[i])
        run.identified["air_fraction"] = True
        run.strengths["seal_stick_slip"] = float(seal[i])
        run.named = ["seal_stick_slip"] if seal[i] > 1.0 else []
    return fleet


def carry_air(rng: np.random.Generator, fleet: list[Run], rise: float = 1.0) -> list[Run]:
    """The seal named in every run and the improved model's air fraction refitted in each.

    The LTI air fraction is left unidentified (as beside a real seal); the improved model's
    sits at an offset within the band with the steady fleet's scatter, and rises ``rise``
    times from the first run to the last.
    """
    sigma = PRIOR_SIGMA["air_fraction"]
    runs = len(fleet)
    level = rng.uniform(-0.6, 0.6) * sigma + _scatter(rng, runs, rng.uniform(0.02, 0.33) * sigma)
    level += math.log(rise) * np.linspace(0.0, 1.0, runs)
    for i, run in enumerate(fleet):
        run.identified["air_fraction"] = False
        run.improved["air_fraction"] = float(level[i])
        run.named = ["seal_stick_slip"]
    return fleet


def rows(fleet: list[Run], rig: str = "test rig", rig_hash: str = "r" * 64) -> list[DiagnosisRow]:
    """Store rows of a fleet (one a day), as :meth:`ResultsStore.diagnoses` returns them."""
    result = []
    for i, run in enumerate(fleet):
        calibration = tuple(
            CalibrationValue(
                name,
                math.exp(run.logs[name]),
                sigma,
                (0.1 if run.identified[name] else 0.9) * sigma,
                math.exp(run.improved[name]) if name in run.improved else None,
            )
            for name, sigma in PRIOR_SIGMA.items()
        )
        hypotheses = tuple(
            HypothesisRow(name, name in run.named, 10.0 ** run.strengths[name], 0.0, {})
            for name in SINGLES
        )
        result.append(
            DiagnosisRow(
                run_id=i + 1,
                recording_path=f"bags/run_{i:03d}",
                recording_hash=f"{i:064x}",
                start_ns=START_NS + i * DAY_NS,
                end_ns=START_NS + i * DAY_NS + 18 * 10**9,
                rig_name=rig,
                rig_hash=rig_hash,
                rig_path="rig.yaml",
                tool_version="0.1.0",
                written_at="2026-01-01T00:00:00+00:00",
                effects=tuple(run.named),
                confidence=0.9 if run.named else 0.95,
                explanation="synthetic",
                calibration=calibration,
                hypotheses=hypotheses,
                metrics={},
            )
        )
    return result


def document(run: Run, recording: str = "bags/synthetic") -> dict[str, Any]:
    """A diagnosis document (the real one, its numbers replaced by the run's)."""
    doc = real_document()
    doc["recording"] = recording
    calibration = doc["calibration"]
    for name, sigma in PRIOR_SIGMA.items():
        calibration["multipliers"][name] = math.exp(run.logs[name])
        calibration["posterior_sigma"][name] = (0.1 if run.identified[name] else 0.9) * sigma
    calibration["not_identified"] = [n for n, ok in run.identified.items() if not ok]
    for hypothesis in doc["hypotheses"]:
        if hypothesis["effect"] in run.strengths:
            hypothesis["held_out_improvement"] = 10.0 ** run.strengths[hypothesis["effect"]]
    doc["verdict"]["effects"] = list(run.named)
    doc["improved"]["effects"] = list(run.named)
    return doc
