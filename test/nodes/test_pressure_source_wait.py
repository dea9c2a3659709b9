"""The pressure source says what it waits for while it waits, and starts when the wait ends."""

from __future__ import annotations

from pathlib import Path

from brake_hil.app.chain import start_node, stop_node
from test.conftest import PROJECT
from test.nodes.harness import ros_domain, unique_domain_id

BAG = PROJECT / "bags" / "one_washer_lti"


def test_the_source_names_the_missing_subscribers_every_few_seconds_then_starts(
    tmp_path: Path,
) -> None:
    with ros_domain(unique_domain_id()) as env:
        source = start_node(
            "pressure_source",
            {
                "recording": str(BAG),
                "duration": 0.5,
                "exit_at_end": True,
                "wait_for_topics": ["/brake/nobody/listens:2"],
                "wait_timeout": 5.0,
                "start_delay": 0.0,
            },
            env,
            tmp_path,
        )
        try:
            source.process.wait(90)
        finally:
            code = stop_node(source)
    log = (tmp_path / "pressure_source.log").read_text()
    assert code == 0, log
    waiting = [line for line in log.splitlines() if "waiting for subscribers" in line]
    assert waiting, log  # said while waiting (every 2 s of a 5 s wait)
    assert all("/brake/nobody/listens (0 of 2)" in line for line in waiting), log
    assert "starting after 5 s without all subscribers: /brake/nobody/listens (0 of 2)" in log
