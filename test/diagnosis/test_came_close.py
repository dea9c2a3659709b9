"""An ``unexplained`` beside a library effect that missed only the generic forms' bar.

Fixtures (``data/familyc_*.summary.json``) are the decision inputs of two family-c cases
(``brake-hil cases --count 28 --seed 8103 --family c``): case 015, a stick-slip seal (Maxwell-slip,
strength 0.23) read through family c's measurement chain, whose drifting transducer zeros
leave a slow misfit of ``p_b`` beside the seal's (stick-slip cuts the held-out error 1.9
times and passes every rule, a free resonance form 2.9 times); and case 008, a 0.76 ms
delay of ``p_b`` under the same drift, which no library effect cuts the required ratio (the
delay 1.30 times). Without the chain's drift the seal is named (cut 7.0 times) and so is
the delay (6.3 times): docs/benchmarks.md. And a null of ``--seed 8233 --family c`` (case
000), ``unexplained`` beside a library effect that passed every rule but the forms' bar,
whose posterior gives ``unexplained`` almost nothing (none takes 0.89).
The confidence is how often verdicts like each were right (:mod:`.reliability`).
"""

from __future__ import annotations

import json
from pathlib import Path
import re

from brake_hil.diagnosis.summary import Summary
from brake_hil.diagnosis.verdict import CAME_CLOSE, decide, decide_effects

DATA = Path(__file__).parent / "data"


def stored(name: str) -> Summary:
    return Summary.from_dict(json.loads((DATA / f"{name}.summary.json").read_text()))


def test_an_unexplained_beside_a_close_library_effect_is_doubted_in_words() -> None:
    """Stick-slip cleared every rule but the forms' bar: ``unexplained``, said with the
    doubt beside its number, and less sure than an ``unexplained`` nothing came near."""
    summary = stored("familyc_seal_drift")
    verdict = decide(summary)
    assert verdict.effects == ("unexplained",)
    assert verdict.capped == CAME_CLOSE
    assert verdict.confidence < 0.5  # was the posterior share, 0.98
    assert re.fullmatch(r"0\.\d\d, a library effect came close: .+", verdict.confidence_text())
    assert verdict.confidence < decide(stored("familyc_delay_drift")).confidence


def test_an_unexplained_no_library_effect_came_near_is_not_doubted() -> None:
    """The best single cut 1.30 times, under the required 1.5: nothing came close."""
    verdict = decide(stored("familyc_delay_drift"))
    assert verdict.effects == ("unexplained",)
    assert verdict.capped is None
    assert verdict.confidence > 0.5
    assert re.fullmatch(r"0\.\d\d", verdict.confidence_text())


def test_the_cap_is_a_pure_function_of_the_stored_inputs() -> None:
    """Replayed from its JSON, the same verdict, words and confidence."""
    summary = stored("familyc_seal_drift")
    again = Summary.from_dict(json.loads(json.dumps(summary.as_dict())))
    assert decide(again) == decide(summary)
    assert decide_effects(again).capped == CAME_CLOSE


def test_a_close_effect_is_said_whatever_the_posterior() -> None:
    """The posterior gives this ``unexplained`` almost nothing; the doubt is still said,
    and the confidence is how often doubted ``unexplained`` verdicts were right."""
    summary = stored("familyc_null_close")
    verdict = decide(summary)
    assert verdict.effects == ("unexplained",)
    assert verdict.capped == CAME_CLOSE
    assert verdict.confidence < 0.5
