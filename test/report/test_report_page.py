"""The diagnosis report as one self-contained page that says what to do next, in plain words.

One diagnosis of a short virtual-rig recording with a compliant hose (module fixture), its
report read as a test engineer reads it; the words' helpers alone below it.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
import re
import shutil

import numpy as np
import pytest

from brake_hil.app.diagnose import run_diagnose
from brake_hil.io.recording_writer import save_recording
from brake_hil.physics.rig import load_rig
from brake_hil.report.diagnosis_figures import (
    TRACES_AREA,
    TRACES_NRMSE,
    TRACES_WORST,
    loop_area_ratio,
    loop_caption,
    loop_nrmse,
    loop_worst,
)
from brake_hil.report.diagnosis_report import _multiplier_words, nrmse_as_fraction
from brake_hil.report.embed import DATA_URI_PREFIX
from brake_hil.report.next_steps import next_steps, noise_words
from brake_hil.virtual_rig.effects import make_effect
from brake_hil.virtual_rig.excitation import seed_pulsing
from brake_hil.virtual_rig.simulator import simulate_rig
from test.conftest import CONFIG, PROJECT


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """A hose recording whose x_c probe reached the end of its range, diagnosed; the output
    folder and the page's HTML."""
    root = tmp_path_factory.mktemp("report")
    rig = load_rig(CONFIG / "rig_default.yaml")
    run = simulate_rig(
        rig,
        [make_effect("hose_compliance", 1.0)],
        seed_pulsing((1.38e6, 2.76e6), pulsing_s=3.0),
        seed=3,
    )
    recording = root / "hose"
    measured = run.as_recording()
    assert measured.caliper_displacement is not None
    end = 0.9 * float(np.min(measured.caliper_displacement))
    held = np.maximum(measured.caliper_displacement, end)
    save_recording(recording, dataclasses.replace(measured, caliper_displacement=held))
    shutil.copy(CONFIG / "rig_default.yaml", root / "rig.yaml")
    out = root / "out"
    result = run_diagnose(recording, root / "rig.yaml", out)
    return out, result.report_path.read_text(encoding="utf-8")


def test_the_report_is_one_self_contained_file(report: tuple[Path, str]) -> None:
    out, page = report
    assert sorted(p.name for p in out.iterdir()) == [
        "diagnosis.json",
        "improved_model.json",
        "report.html",
    ]
    sources = re.findall(r'<img src="([^"]+)"', page)
    assert len(sources) == 4
    assert all(s.startswith(DATA_URI_PREFIX) and len(s) > 20_000 for s in sources)


def test_the_verdicts_row_is_marked_and_the_order_explained(report: tuple[Path, str]) -> None:
    _, page = report
    [row] = re.findall(r'<tr class="verdict"><td>([^<]*)<span class=flag>', page)
    assert row.strip() == "hose_compliance"
    assert re.search(r"The verdict is marked \(row \d+ of \d+\)\. Rows are in order of", page)


def test_next_steps_give_the_command_to_run_the_improved_model_live(
    report: tuple[Path, str],
) -> None:
    out, page = report
    steps = page[page.index("<h2>Next steps</h2>") :]
    recording = out.parent / "hose"
    assert f"bash scripts/run_chain.sh {recording} --model {out / 'improved_model.json'}" in steps
    assert "the hose" in steps  # the catalogue's rig check
    start = page.index("<b>What to check on the rig:</b>")
    checks = page[start : page.index("<h2>", start)]
    assert re.search(r"x_c is held at -\d+\.\d um in \d+\.\d % of the samples", checks)
    assert "Widen the range and test again" in steps
    assert "brake-hil diagnose NEW_RECORDING" in steps and "brake-hil regress" in steps


def test_every_nrmse_on_the_page_is_one_measure_on_one_scale(report: tuple[Path, str]) -> None:
    _, page = report
    text = re.sub(r"<[^>]+>", " ", re.sub(r'src="[^"]+"', "", page))
    assert not re.search(r"NRMSE %|% NRMSE|NRMSE(?: at most)? \d+\.\d+ %", text)
    values = re.findall(r"NRMSE(?: at most)? (\d+(?:\.\d+)?(?:e-\d+)?)", text)
    assert values and all(float(v) < 1.5 for v in values)  # fractions, as compare prints
    assert "held-out error</b> is the diagnosis's own measure" in page
    assert "times the noise's" not in text and "sensor noise (RMS)" in text
    assert not re.search(r">x\d", page)  # no "x0.024 (-7.5)"


def test_the_loop_caption_says_when_the_improved_model_does_not_trace_it() -> None:
    phase = np.linspace(0, 4 * np.pi, 400)
    measured = (np.cos(phase), np.sin(phase))
    flat = (np.cos(phase), 0.2 * np.sin(phase))
    assert loop_nrmse(measured, measured) == 0.0
    error = loop_nrmse(flat, measured)
    assert error > TRACES_NRMSE
    caption = loop_caption(0.5, error)
    assert f"does not trace the measured loop here (NRMSE {error:.2g})" in caption
    assert (
        "traces the measured loop (NRMSE 0.03, at worst 6 % of its span off; it encloses 0.90"
        in (loop_caption(0.5, 0.03, 0.9, 0.06))
    )
    # a sharp-cornered loop over a rounded one: NRMSE and area held, 10 % off at a corner
    cornered = loop_caption(0.27, 0.054, 0.88, 0.102)
    assert "follows the measured loop's extent (NRMSE 0.054) but not its shape" in cornered
    assert "at worst 10 % of its span off; it encloses 0.88" in cornered
    square = (np.clip(1.5 * np.cos(phase), -1, 1), np.clip(1.5 * np.sin(phase), -1, 1))
    assert loop_worst(square, measured) > TRACES_WORST >= loop_worst(measured, measured)
    # a thin seal loop: each coordinate within 3 %, but 0.6 of the area (the energy lost per
    # cycle) is enclosed: the shape is not traced
    lens = (np.cos(phase), np.cos(phase) + 0.2 * np.sin(phase))
    thin = (np.cos(phase), np.cos(phase) + 0.12 * np.sin(phase))
    assert loop_nrmse(thin, lens) <= TRACES_NRMSE
    area = loop_area_ratio(thin, lens)
    assert abs(area - 0.6) < 0.01 and abs(area - 1.0) > TRACES_AREA
    shape = loop_caption(0.5, 0.03, area)
    assert "follows the measured loop's extent (NRMSE 0.03) but not its shape" in shape


def test_the_noise_and_the_rig_values_in_plain_words() -> None:
    assert noise_words(62_500.0) == "the LTI model's error is 250 times the sensor noise (RMS)"
    assert noise_words(0.81).startswith("the LTI model's error is within the sensor noise")
    assert _multiplier_words(0.024, -7.5) == "0.024 of the file's value, 7.5 tolerances below"


def test_the_diagnosis_words_get_the_nrmse_as_a_fraction() -> None:
    assert nrmse_as_fraction("(p_b NRMSE 14.16 % -> 2.10 %).") == "(p_b NRMSE 0.1416 -> 0.0210)."
    assert nrmse_as_fraction("by up to 5.16 % NRMSE, 3 times") == "by up to NRMSE 0.0516, 3 times"
    assert nrmse_as_fraction("NRMSE at most 0.80 %") == "NRMSE at most 0.0080"


def test_next_steps_without_named_physics_run_no_improved_model(tmp_path: Path) -> None:
    steps = next_steps("bags/x", tmp_path, None, False, [])
    assert "run_chain" not in steps and "no improved model to run live" in steps


def test_a_doubted_confidence_is_said_with_its_number_and_what_it_means() -> None:
    from types import SimpleNamespace

    from brake_hil.report.diagnosis_report import _confidence_words

    measured = SimpleNamespace(confidence=0.9312, confidence_capped=None)
    capped = SimpleNamespace(confidence=0.41, confidence_capped="not sure it is alone")
    assert _confidence_words(measured) == (  # type: ignore[arg-type]
        "high (confidence 0.93: how often verdicts like this one were right)"
    )
    words = _confidence_words(capped)  # type: ignore[arg-type]
    assert words.startswith("low (confidence 0.41: how often verdicts like this one were right)")
    assert "not sure it is alone" in words


def test_the_reports_runner_up_is_the_explanations_next_hypothesis() -> None:
    """Both name the hypothesis with the next largest share of the posterior (not the one
    with the next largest error cut, which may be a pair a physics check set aside)."""
    from types import SimpleNamespace

    from brake_hil.diagnosis.result import runner_up
    from brake_hil.diagnosis.summary import Summary
    from brake_hil.diagnosis.verdict import decide
    from brake_hil.report.diagnosis_report import _confidence_words

    data = PROJECT / "test" / "diagnosis" / "data" / "lab_seal_weak.summary.json"
    summary = Summary.from_dict(json.loads(data.read_text()))
    verdict = decide(summary)
    rival = runner_up(summary, verdict.effects)
    assert rival is not None
    shown = SimpleNamespace(
        confidence=0.75, confidence_capped=None, summary=summary, effects=verdict.effects
    )
    words = _confidence_words(shown)  # type: ignore[arg-type]
    assert f"check the runner-up, {rival[0]}, at {rival[1]:.2f}" in words


def test_the_explanation_gives_the_nrmse_as_compare_does(report: tuple[Path, str]) -> None:
    out, _ = report
    explanation = json.loads((out / "diagnosis.json").read_text())["verdict"]["explanation"]
    assert not re.search(r"NRMSE %|% NRMSE|NRMSE[^.]*\d+\.\d+ %", explanation), explanation
    assert re.search(r"NRMSE on the held-out cycles 0\.\d{4} with the calibrated LTI", explanation)
