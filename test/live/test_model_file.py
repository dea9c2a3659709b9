"""Model files the live model loads: rig YAML today, a registry for more kinds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from brake_hil.errors import RigError
from brake_hil.live import model_file
from brake_hil.live.model_file import LiveModel, ModelFileError, load_model, register_loader
from test.conftest import CONFIG

RIG = CONFIG / "rig_default.yaml"


def test_a_rig_file_gives_its_lti_model_with_the_model_overrides(tmp_path: Path) -> None:
    plain = load_model(RIG, 1.0e6)
    text = RIG.read_text(encoding="utf-8").replace(
        "  excitation_hz: 5.0", "  excitation_hz: 5.0\n  model: {k_c: 3.4e7, R_v: 4.2e10}"
    )
    overridden_path = tmp_path / "rig.yaml"
    overridden_path.write_text(text, encoding="utf-8")
    overridden = load_model(overridden_path, 1.0e6)
    assert plain.parameters is not None and overridden.parameters is not None
    assert overridden.parameters.caliper_stiffness == 3.4e7
    assert "overrides: R_v, k_c" in overridden.description
    pressure = 1e6 + 3e5 * np.sin(np.arange(400) * 2 * np.pi * 5e-3)
    assert not np.allclose(plain.batch(pressure), overridden.batch(pressure))


def test_the_stepper_and_the_batch_of_a_model_agree() -> None:
    model = load_model(RIG, 1.5e6)
    pressure = 1.5e6 + 5e5 * np.sin(np.arange(1000) * 2 * np.pi * 5e-3)
    stepper = model.stepper()
    live = np.array([stepper.step(float(p)) for p in pressure]).T
    batch = model.batch(pressure)
    assert np.max(np.abs(live - batch) / np.ptp(batch, axis=1)[:, None]) < 1e-12


def test_missing_and_unknown_model_files_are_refused_by_name(tmp_path: Path) -> None:
    with pytest.raises(ModelFileError, match="no such model file"):
        load_model(tmp_path / "absent.yaml")
    unknown = tmp_path / "model.txt"
    unknown.write_text("", encoding="utf-8")
    with pytest.raises(ModelFileError, match="unknown model file kind '.txt'"):
        load_model(unknown)
    bad = tmp_path / "bad.yaml"
    bad.write_text(RIG.read_text().replace("mass: 2.5", "mass: -2.5"), encoding="utf-8")
    with pytest.raises(RigError, match="caliper.mass"):
        load_model(bad)


def test_a_registered_loader_reads_its_kind(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(model_file, "_LOADERS", dict(model_file._LOADERS))
    seen: list[tuple[Path, float]] = []

    def load_improved(path: Path, mean_pressure: float) -> LiveModel:
        seen.append((path, mean_pressure))
        return load_model(RIG, mean_pressure)

    register_loader(".json", load_improved)
    path = tmp_path / "improved.json"
    path.write_text("{}", encoding="utf-8")
    assert load_model(path, 1.2e6).mean_pressure == 1.2e6
    assert seen == [(path, 1.2e6)]
