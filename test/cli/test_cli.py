"""``brake-hil`` on the command line: results on good recordings, exit 2 on bad input."""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from brake_hil import __version__
from brake_hil.analysis.comparison import predict
from brake_hil.io.recording_writer import write_recording
from brake_hil.physics.catalogue import effect_names
from brake_hil.physics.excitation import pulsing_profile
from brake_hil.physics.parameters import derive_parameters
from brake_hil.physics.rig import Rig
from brake_hil.report.diagnosis_report import NRMSE_DEFINITION
from brake_hil.topics import (
    BLOCK_FORCE,
    BORE_PRESSURE,
    CALIPER_DISPLACEMENT,
    MASTER_CYLINDER_PRESSURE,
)
from test.conftest import CONFIG, PEER_DATA

RIG = CONFIG / "rig_default.yaml"


def brake_hil(*args: str | Path, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """Run the console entry point as a user would, in a fresh interpreter."""
    return subprocess.run(
        [sys.executable, "-m", "brake_hil.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=cwd,
    )


def _write(path: Path, rig: Rig, *, pressure_scale: float = 1.0, edit=None) -> Path:  # type: ignore[no-untyped-def]
    time, pressure = pulsing_profile((1.38e6,), pulsing_s=4.0)
    outputs = predict(pressure, derive_parameters(rig, 1.08e6))
    channels = {
        MASTER_CYLINDER_PRESSURE: pressure * pressure_scale,
        BORE_PRESSURE: outputs["p_b"],
        BLOCK_FORCE: outputs["F_k"],
        CALIPER_DISPLACEMENT: outputs["x_c"],
    }
    if edit is not None:
        edit(channels)
    return write_recording(path, time, channels)


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory, default_rig: Rig) -> Path:
    return _write(tmp_path_factory.mktemp("rec") / "one_washer", default_rig)


def test_compare_of_the_model_on_its_own_output_is_perfect(
    recording: Path, tmp_path: Path
) -> None:
    result = brake_hil(
        "compare",
        recording,
        "--rig",
        RIG,
        "--json",
        tmp_path / "c.json",
        "--plot",
        tmp_path / "c.png",
    )
    assert result.returncode == 0, result.stderr
    metrics = json.loads((tmp_path / "c.json").read_text())["metrics"]
    assert set(metrics) == {"p_b", "F_k", "x_c"}
    for channel in metrics.values():
        assert channel["ptp_ratio_pct"] == pytest.approx(100.0, abs=0.5)
        assert abs(channel["tau_over_T_pct"]) < 0.2
        assert channel["nrmse"] < 0.005
    assert (tmp_path / "c.png").stat().st_size > 10_000
    assert "p_b" in result.stdout and "ptp ratio" in result.stdout


def test_compare_sees_a_stiffer_caliper_in_x_c_but_not_in_p_b(
    tmp_path: Path, default_rig: Rig
) -> None:
    stiffer = Rig(**{**default_rig.__dict__, "caliper_stiffness": 6.0e7})
    bag = _write(tmp_path / "stiff", stiffer)
    result = brake_hil("compare", bag, "--rig", RIG, "--json", tmp_path / "c.json")
    assert result.returncode == 0, result.stderr
    metrics = json.loads((tmp_path / "c.json").read_text())["metrics"]
    assert metrics["x_c"]["ptp_ratio_pct"] > 120.0  # nominal caliper is softer: over-predicts
    assert metrics["p_b"]["ptp_ratio_pct"] == pytest.approx(100.0, abs=3.0)


def test_characterize_writes_table_3_per_segment(recording: Path, tmp_path: Path) -> None:
    result = brake_hil("characterize", recording, "--rig", RIG, "--json", tmp_path / "t3.json")
    assert result.returncode == 0, result.stderr
    segments = json.loads((tmp_path / "t3.json").read_text())["segments"]
    assert len(segments) == 1
    segment = segments[0]
    for key in (
        "t_start",
        "t_end",
        "max_pressure",
        "ptp_pressure",
        "k_eh",
        "c_eh",
        "k_eh_star",
        "eta_eh",
        "c_fs",
        "c_ss",
        "c_fb",
        "xi",
    ):
        assert np.isfinite(segment[key]), key
    assert segment["k_eh_star"] == pytest.approx(0.29, rel=0.01)
    assert segment["eta_eh"] == pytest.approx(0.93, rel=0.01)


def test_simulate_writes_a_recording_that_compare_reads(tmp_path: Path) -> None:
    out = tmp_path / "sim"
    assert (
        brake_hil("simulate", "--rig", RIG, "--out", out, "--pulsing-seconds", "3").returncode == 0
    )
    assert (out / "metadata.yaml").exists()
    again = brake_hil("simulate", "--rig", RIG, "--out", out)
    assert again.returncode == 2 and "already exists" in again.stderr
    assert brake_hil("compare", out, "--rig", RIG).returncode == 0


def _single_error_line(result: subprocess.CompletedProcess[str]) -> str:
    assert result.returncode == 2, (result.stdout, result.stderr)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    return lines[0]


def test_missing_recording_exits_2_naming_it(tmp_path: Path) -> None:
    line = _single_error_line(brake_hil("compare", tmp_path / "nope", "--rig", RIG))
    assert "nope" in line


def test_truncated_bag_exits_2(recording: Path, tmp_path: Path) -> None:
    broken = tmp_path / "broken"
    shutil.copytree(recording, broken)
    mcap = next(broken.glob("*.mcap"))
    data = mcap.read_bytes()
    mcap.write_bytes(data[:2000])  # not one whole chunk left
    line = _single_error_line(brake_hil("compare", broken, "--rig", RIG))
    assert "broken" in line and "not one whole chunk" in line


def test_a_cut_bag_is_compared_on_its_whole_chunks_and_says_so(
    recording: Path, tmp_path: Path
) -> None:
    cut = tmp_path / "cut"
    shutil.copytree(recording, cut)
    mcap = next(cut.glob("*.mcap"))
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) * 9 // 10])  # a writer killed near the end
    result = brake_hil("compare", cut, "--rig", RIG)
    assert result.returncode == 0, result.stderr
    (note,) = result.stderr.strip().splitlines()
    assert note.startswith(f"{cut}: unfinished recording") and "recovered" in note
    assert "NRMSE" in result.stdout or "nrmse" in result.stdout.lower()
    recovered = brake_hil("recover", cut, "--out", tmp_path / "copy")
    assert recovered.returncode == 0, recovered.stderr
    assert "unfinished" in recovered.stdout.splitlines()[0]
    again = brake_hil("compare", tmp_path / "copy", "--rig", RIG)
    assert again.returncode == 0 and again.stderr == ""  # the copy is finished
    assert again.stdout == result.stdout.replace(str(cut), str(tmp_path / "copy"))


def test_missing_topic_exits_2_listing_what_is_there(tmp_path: Path, default_rig: Rig) -> None:
    bag = _write(tmp_path / "no_force", default_rig, edit=lambda c: c.pop(BLOCK_FORCE))
    line = _single_error_line(brake_hil("compare", bag, "--rig", RIG))
    assert "/brake/block/force" in line and "/brake/bore/pressure" in line


def test_nan_samples_exit_2(tmp_path: Path, default_rig: Rig) -> None:
    def poison(channels):  # type: ignore[no-untyped-def]
        channels[BORE_PRESSURE] = channels[BORE_PRESSURE].copy()
        channels[BORE_PRESSURE][1234] = np.nan

    bag = _write(tmp_path / "nan", default_rig, edit=poison)
    line = _single_error_line(brake_hil("compare", bag, "--rig", RIG))
    assert "nan" in line.lower() and "/brake/bore/pressure" in line


def test_stamps_going_backwards_exit_2(tmp_path: Path, default_rig: Rig) -> None:
    from brake_hil.io.recording_writer import TopicSeries, write_topics

    time, pressure = pulsing_profile((1.38e6,), pulsing_s=2.0)
    outputs = predict(pressure, derive_parameters(default_rig))
    stamps = (1_700_000_000_000_000_000 + np.round(time * 1e9)).astype(np.int64)
    jumped = stamps.copy()  # the rig clock jumps back once; messages are logged in order
    jumped[500], jumped[501] = jumped[501], jumped[500]
    series = {
        MASTER_CYLINDER_PRESSURE: TopicSeries(jumped, pressure, stamps),
        BORE_PRESSURE: TopicSeries(stamps, outputs["p_b"]),
        BLOCK_FORCE: TopicSeries(stamps, outputs["F_k"]),
        CALIPER_DISPLACEMENT: TopicSeries(stamps, outputs["x_c"]),
    }
    bag = write_topics(tmp_path / "clock_jump", series)
    line = _single_error_line(brake_hil("compare", bag, "--rig", RIG))
    assert "clock_jump" in line and "go backwards at sample 501" in line


def test_bad_rig_key_exits_2_naming_the_key(recording: Path, tmp_path: Path) -> None:
    rig = tmp_path / "bad_rig.yaml"
    rig.write_text(RIG.read_text().replace("mass: 2.5", "mass: -2.5"))
    line = _single_error_line(brake_hil("compare", recording, "--rig", rig))
    assert "bad_rig.yaml" in line and "caliper.mass" in line


def test_recording_without_steady_pulsing_is_compared_per_segment(tmp_path: Path) -> None:
    # Refused (exit 2) before any excitation but steady pulsing was scored; a ramp is a
    # ramp now, scored on its static map; characterize still needs pulsing or a sweep.
    time = np.arange(0.0, 3.0, 1e-3)
    ramp = 1e6 * time
    bag = write_recording(
        tmp_path / "ramp",
        time,
        {
            MASTER_CYLINDER_PRESSURE: ramp,
            BORE_PRESSURE: ramp,
            BLOCK_FORCE: ramp * 1e-3,
            CALIPER_DISPLACEMENT: -ramp * 1e-11,
        },
    )
    done = brake_hil("compare", bag, "--rig", RIG)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "ramp" in done.stdout and "over non idle segments:" in done.stdout
    line = _single_error_line(brake_hil("characterize", bag, "--rig", RIG))
    assert "ramp" in line and "5 Hz or a sweep" in line


@pytest.mark.parametrize(
    "bag",
    [
        "mcap/talker",
        "mcap/wbag",
        "mcap/cdr_test",
        "mcap/bag_with_topics_and_service_events",
        "sqlite3/talker",
        "sqlite3/wbag",
    ],
)
def test_rosbag2s_own_bags_are_opened_and_the_brake_topics_named_missing(bag: str) -> None:
    path = PEER_DATA / "rosbag2" / bag
    if not path.exists():
        pytest.skip(
            f"peer data not found at {path} (set BRAKE_HIL_PEER_DATA, or shared/peer-data "
            "beside the checkout)"
        )
    line = _single_error_line(brake_hil("compare", path, "--rig", RIG))
    assert "/brake/master_cylinder/pressure" in line
    assert "the recording holds" in line


def test_diagnose_on_a_parameter_error_only_finds_no_missing_physics(tmp_path: Path) -> None:
    """A virtual-rig recording whose caliper is 15 % softer than the rig file says."""
    truth = tmp_path / "truth.yaml"
    truth.write_text(RIG.read_text().replace("stiffness: 4.0e7", "stiffness: 3.4e7"))
    bag = tmp_path / "rec"
    made = brake_hil(
        "simulate",
        "--rig",
        truth,
        "--out",
        bag,
        "--engine",
        "virtual",
        "--max-pressure",
        "1.38e6",
        "2.76e6",
        "--pulsing-seconds",
        "3",
        "--seed",
        "4",
    )
    assert made.returncode == 0, made.stderr
    (tmp_path / "rec.rig.yaml").write_text(RIG.read_text())  # the rig file beside the bag
    # Without --rig and --out: RECORDING.rig.yaml beside it, out/<recording name>/.
    result = brake_hil("diagnose", "rec/", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "rig file: rec.rig.yaml (beside the recording" in result.stdout
    assert "output folder: out/rec (" in result.stdout
    # stderr is no terminal: progress as lines (no carriage returns), never past its total.
    assert "\r" not in result.stderr
    steps = [
        tuple(map(int, m))
        for m in re.findall(r"diagnose: +\d+%\|[^|]*\| (\d+)/(\d+)", result.stderr)
    ]
    assert steps and all(done <= total for done, total in steps), result.stderr
    assert steps[-1][0] == steps[-1][1]
    (tmp_path / "d").symlink_to(tmp_path / "out" / "rec")
    diagnosis = json.loads((tmp_path / "d" / "diagnosis.json").read_text())
    assert diagnosis["verdict"]["effects"] == []
    assert set(diagnosis["baseline"]["metrics"]) == {"p_b", "F_k", "x_c"}
    assert {h["effect"] for h in diagnosis["hypotheses"]} >= set(effect_names())
    assert diagnosis["decision_inputs"]["noise_cost"] > 0
    multipliers = diagnosis["calibration"]["multipliers"]
    assert multipliers["caliper_stiffness"] == pytest.approx(3.4e7 / 4.0e7, rel=0.03)
    for name in ("report.html", "improved_model.json"):
        assert (tmp_path / "d" / name).stat().st_size > 500, name
    _check_report(tmp_path / "d" / "report.html")


def _check_report(page: Path) -> None:
    """What a reader of report.html must find."""
    text = html.unescape(page.read_text())
    assert text.count(NRMSE_DEFINITION) == 1  # one NRMSE, defined once
    assert "the held-out error's scale, not NRMSE's" in text  # the other is not NRMSE
    assert "``" not in text
    assert text.index("In short") < text.index("The paper's metrics") < text.index("Hypotheses")
    assert "rec.rig.yaml" in text and f"brake_hil {__version__}" in text
    assert re.search(r"<b>Recording:</b> \S+ \(\d+\.\d s\)", text)  # its length
    # The top row (best held-out fit) is not the verdict (none): the page says why.
    assert "Why the top row is not the verdict:" in text
    images = re.findall(r'<img src="([^"]+)"', text)
    assert len(images) == 4
    for source in images:  # inside the page: it is mailed alone
        assert source.startswith("data:image/png;base64,")
        png = base64.b64decode(source.split(",", 1)[1])
        assert png[:8] == b"\x89PNG\r\n\x1a\n"
        width = int.from_bytes(png[16:20], "big")
        assert width >= 900, width  # 130 dpi: readable legends


@pytest.mark.parametrize("command", ["diagnose", "benchmark"])
def test_diagnose_and_benchmark_refuse_bad_input_with_one_line(
    command: str, tmp_path: Path
) -> None:
    if command == "diagnose":
        args = ["diagnose", tmp_path / "nothing", "--rig", RIG, "--out", tmp_path / "d"]
    else:
        args = ["benchmark", tmp_path / "empty"]
    line = _single_error_line(brake_hil(*args))
    assert str(tmp_path) in line


BAGS = Path(__file__).resolve().parents[2] / "bags"


def _idle(tmp_path: Path) -> Path:
    """A recording of sensor noise at rest: nothing to compare."""
    time = np.arange(0.0, 3.0, 1e-3)
    noise = np.random.default_rng(0).normal(0.0, 1.5e3, time.size)
    channels = {
        MASTER_CYLINDER_PRESSURE: 5e3 + noise,
        BORE_PRESSURE: 5e3 + noise[::-1],
        BLOCK_FORCE: 5.0 + noise * 1e-3,
        CALIPER_DISPLACEMENT: -1e-6 + noise * 1e-12,
    }
    shutil.copy(RIG, tmp_path / "idle.rig.yaml")
    return write_recording(tmp_path / "idle", time, channels)


@pytest.mark.parametrize(
    "command",
    [
        ["diagnose", "{missing}"],
        ["diagnose", "{missing}", "--rig", RIG],
        ["compare", "{missing}", "--json", "out/c.json", "--db", "out/r.sqlite"],
        ["characterize", "{missing}", "--json", "out/c.json"],
        ["regress", "{missing}", "--baseline", "out/b.json", "--update", "--db", "out/r.sqlite"],
        # refused once opened (nothing but idle; a ramp to characterise): the folders made
        # for it are gone again
        ["compare", "{idle}", "--json", "out/x/c.json", "--db", "out/r.sqlite"],
        ["characterize", "{ramp}", "--json", "out/c.json"],
    ],
)
def test_a_refused_command_writes_nothing(command: list[str | Path], tmp_path: Path) -> None:
    missing = tmp_path / "bags" / "hose_compliance"  # a typo of effect_hose_compliance
    paths = {"{missing}": missing, "{ramp}": BAGS / "ramp_one_washer"}
    if "{idle}" in command:
        paths["{idle}"] = _idle(tmp_path)
    args = [paths.get(str(arg), arg) for arg in command]
    done = brake_hil(*args, cwd=tmp_path)
    assert done.returncode == 2, done.stdout + done.stderr
    errors = [line for line in done.stderr.splitlines() if "error:" in line]
    assert len(errors) == 1 and "Traceback" not in done.stderr
    if args[1] == missing:
        assert errors[0] == f"brake-hil {command[0]}: error: {missing}: no such recording"
    assert not (tmp_path / "out").exists(), list((tmp_path / "out").rglob("*"))


def test_compare_and_characterize_default_to_the_rig_file_beside_the_recording(
    tmp_path: Path,
) -> None:
    bag = BAGS / "five_washer_open"
    beside = BAGS / "five_washer_open.rig.yaml"
    for command in ("compare", "characterize"):
        done = brake_hil(command, bag)
        assert done.returncode == 0, done.stderr
        assert f"rig file: {beside} (beside the recording; --rig to choose another)" in (
            done.stderr.splitlines()
        )
        assert f"recording {bag}  rig {beside} (" in done.stdout
    told = brake_hil("compare", bag, "--rig", RIG, "--json", tmp_path / "c.json")
    assert told.returncode == 0, told.stderr
    assert "rig file:" not in told.stderr and f"rig {RIG} (" in told.stdout
    assert json.loads((tmp_path / "c.json").read_text())["rig"] == str(RIG)
