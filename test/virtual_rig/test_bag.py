"""Virtual-rig recordings: every sample, stamp and value intact through an independent reader."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
import numpy as np
import pytest

from brake_hil.io.recording_reader import read_recording
from brake_hil.io.recording_writer import DEFAULT_START_STAMP_NS
from brake_hil.physics.rig import Rig, load_rig
from brake_hil.topics import QUANTITY_TOPICS
from brake_hil.virtual_rig import simulate_rig, solenoid_pulsing
from brake_hil.virtual_rig.bag import write_run
from brake_hil.virtual_rig.rig_yaml import dump_rig, rig_to_mapping, rig_with_values, write_rig
from test.virtual_rig.conftest import RunFactory


def _field(message: object, dotted: str) -> float:
    for part in dotted.split("."):
        message = getattr(message, part)
    return float(message)  # type: ignore[arg-type]


def test_recording_reads_back_with_mcap_ros2_sample_for_sample(
    tmp_path: Path, nominal_rig: Rig
) -> None:
    run = simulate_rig(
        nominal_rig, (), solenoid_pulsing(nominal_rig, (1.38e6,), ramp_s=0.3, pulsing_s=0.4)
    )
    path = write_run(run, tmp_path / "air", nominal_rig=nominal_rig)
    files = sorted(path.glob("*.mcap"))
    assert (path / "metadata.yaml").is_file() and len(files) == 1
    stamps: dict[str, list[int]] = {}
    values: dict[str, list[float]] = {}
    by_topic = {spec.name: (key, spec) for key, spec in QUANTITY_TOPICS.items()}
    with files[0].open("rb") as stream:
        reader = make_reader(stream, validate_crcs=True, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, _message, decoded in reader.iter_decoded_messages():
            key, spec = by_topic[channel.topic]
            assert schema is not None and schema.name == spec.msgtype
            stamps.setdefault(key, []).append(
                decoded.header.stamp.sec * 1_000_000_000 + decoded.header.stamp.nanosec
            )
            values.setdefault(key, []).append(_field(decoded, spec.field))
    assert sorted(stamps) == sorted(run.measured) == ["F_k", "p_a", "p_b", "p_i", "x_c"]
    expected_stamps = DEFAULT_START_STAMP_NS + np.round(run.time * 1e9).astype(np.int64)
    for key, measured in run.measured.items():
        assert np.array_equal(np.array(stamps[key]), expected_stamps), key
        assert np.array_equal(np.array(values[key]), measured), key
    recording = read_recording(path)
    assert np.array_equal(recording.caliper_displacement, run.measured["x_c"])
    assert np.array_equal(recording.air_pressure, run.measured["p_a"])


def test_recording_comes_with_the_nominal_rig_file(
    tmp_path: Path, rig_run: RunFactory, nominal_rig: Rig
) -> None:
    run = rig_run(pulsing_s=0.6)
    believed = rig_with_values(nominal_rig, {"caliper.stiffness": 4.4e7})
    write_run(run, tmp_path / "rec", nominal_rig=believed)
    loaded = load_rig(tmp_path / "rec.rig.yaml")
    assert loaded.caliper_stiffness == 4.4e7
    assert rig_to_mapping(loaded) == rig_to_mapping(believed)
    with pytest.raises(FileExistsError):
        write_run(run, tmp_path / "rec")


def test_rig_yaml_round_trips_exactly(tmp_path: Path, nominal_rig: Rig) -> None:
    odd = rig_with_values(
        nominal_rig, {"caliper.stiffness": 3.123456789012e7, "fluid.air_fraction": 1.7e-05}
    )
    path = write_rig(odd, tmp_path / "odd.yaml", "a comment\nover two lines")
    assert rig_to_mapping(load_rig(path)) == rig_to_mapping(odd)
    text = dump_rig(nominal_rig)
    assert "stiffness: 4.0e7" in text and "!!" not in text
    assert "air_fraction: 1.7e-5" in path.read_text()
