"""The diagnosis on a recording as the recorder node writes it (streamed, split rosbag2 MCAP).

The recorder streams the CDR messages it receives into ``McapRecorder``; here the messages of
a virtual-rig run go through the same writer, interleaved as they arrive (one per topic per
millisecond, logged after their stamp, with predictions the diagnosis must ignore), split
into files of 4 s, and ``brake-hil diagnose`` runs on the directory.
"""

from __future__ import annotations

import json
from pathlib import Path
import subprocess
import sys

import numpy as np

from brake_hil.io.mcap_recorder import McapRecorder
from brake_hil.io.stamped_cdr import encode_stamped
from brake_hil.physics.rig import load_rig
from brake_hil.topics import OUTPUT_CHANNELS, PREDICTED_OUTPUTS, QUANTITY_TOPICS
from brake_hil.virtual_rig.effects import make_effect
from brake_hil.virtual_rig.excitation import seed_pulsing
from brake_hil.virtual_rig.simulator import simulate_rig
from test.conftest import CONFIG, PROJECT

T0 = 1_763_000_000_000_000_000  # ns
RIG = CONFIG / "rig_default.yaml"


def test_diagnose_names_the_effect_in_a_split_recorder_mcap(tmp_path: Path) -> None:
    run = simulate_rig(
        load_rig(RIG),
        [make_effect("orifice_flow", 1.0)],
        seed_pulsing((1.38e6, 2.76e6), pulsing_s=3.0),
        seed=3,
    )
    stamps = T0 + np.round(run.time * 1e9).astype(np.int64)
    topics = [(QUANTITY_TOPICS[key], values) for key, values in run.measured.items()] + [
        (spec, run.measured[key] * 1.01) for spec, key in zip(PREDICTED_OUTPUTS, OUTPUT_CHANNELS)
    ]
    bag = tmp_path / "recorded"
    with McapRecorder(bag, max_file_duration_s=4.0, chunk_bytes=1 << 16) as recorder:
        rows = []
        for spec, values in topics:
            handle = recorder.add_topic(spec.name, spec.msgtype)
            encoded = encode_stamped(spec.msgtype, spec.field, stamps, values, "rig")
            rows.append((handle, encoded))
        for k, stamp in enumerate(stamps):
            for handle, encoded in rows:
                recorder.write(handle, int(stamp) + 300_000, encoded[k].tobytes())
    assert len(list(bag.glob("*.mcap"))) >= 2

    out = tmp_path / "diagnosis"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "brake_hil.cli",
            "diagnose",
            str(bag),
            "--rig",
            str(RIG),
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr
    document = json.loads((out / "diagnosis.json").read_text())
    verdict = document["verdict"]
    assert verdict["effects"] == ["orifice_flow"], verdict
    # The results tests build their fleets on a kept diagnosis.json: it must still have the
    # shape the command writes (renew it with brake-hil diagnose bags/one_washer_open).
    kept = json.loads(KEPT_DIAGNOSIS.read_text())
    assert set(document) == set(kept)
    for part in ("calibration", "verdict", "baseline", "improved"):
        # only when unexplained, when a single may not be alone, or a rule capped the confidence
        optional = {
            "unexplained_form",
            "not_sure_alone",
            "possible_second_effect",
            "confidence_capped",
            "confidence_cap",
            "air",  # only when the air is named or out of its tolerance
            "groove_asymmetry",  # only with a seal verdict
        }
        assert set(document[part]) - optional == set(kept[part]) - optional, part
    assert set(document["hypotheses"][0]) == set(kept["hypotheses"][0])
    metrics = document["baseline"]["metrics"]["F_k"]
    assert metrics.keys() == kept["baseline"]["metrics"]["F_k"].keys()


KEPT_DIAGNOSIS = PROJECT / "test" / "results" / "diagnosis_one_washer_open.json"
