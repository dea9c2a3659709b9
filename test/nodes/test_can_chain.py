"""The whole chain without hardware over CAN: rig_emulator (CAN frames on an slcan
pseudo-terminal) -> pressure_source (mode can) -> caliper_model -> comparator -> recorder,
each its own process on loopback DDS; the recorded MCAP is checked sample for sample against
the batch model on the recorded input."""

from __future__ import annotations

from pathlib import Path

import pytest

from brake_hil.app.chain import run_can_chain
from test.conftest import CONFIG
from test.nodes.harness import unique_domain_id

pytest.importorskip("serial", reason="python-can's slcan interface needs pyserial")


def test_chain_over_can_predicts_every_sample_the_emulator_sent(tmp_path: Path) -> None:
    lines: list[str] = []
    result = run_can_chain(
        CONFIG / "rig_default.yaml",
        ("sensor_delay=1.0",),
        CONFIG / "rig_default.yaml",
        tmp_path,
        pulsing_s=2.0,
        domain_id=unique_domain_id(),
        progress=lines.append,
    )
    assert result.exit_codes and all(code == 0 for code in result.exit_codes.values()), lines
    assert result.check is not None, lines
    assert result.check["inputs"] == result.check["predictions"] == 3000  # 1 s ramp + 2 s
    for channel in ("p_b", "F_k", "x_c"):
        assert result.check[f"max_dev_{channel}"] < 1e-9
    assert result.comparator is not None
