"""Each process's ROS domain id is its own: a lock per id, held while the process lives."""

from __future__ import annotations

import os
import subprocess
import sys

from brake_hil.app import chain_environment
from brake_hil.app.chain_environment import choose_domain_id


def test_a_second_process_never_gets_a_domain_id_this_one_holds() -> None:
    before = set(chain_environment._held_domains)
    assert int(os.environ["ROS_DOMAIN_ID"]) in before  # test/nodes/conftest.py holds one
    for _ in range(100):
        choose_domain_id()  # every id no other process holds
    held = set(chain_environment._held_domains) - before
    assert held
    free = max(held)  # give one back
    os.close(chain_environment._held_domains.pop(free))
    child = subprocess.run(
        [
            sys.executable,
            "-c",
            "from brake_hil.app.chain_environment import choose_domain_id as c; print(c())",
        ],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    )
    assert int(child.stdout) == free, (child.stdout, free, sorted(held))
    for domain in held - {free}:
        os.close(chain_environment._held_domains.pop(domain))
