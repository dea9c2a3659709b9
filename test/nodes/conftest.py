"""The node tests' ROS domain: one per test process, held so no other process shares it.

Node tests that run at the same time (two pytest processes, a chain beside them) would
otherwise meet on one ``ROS_DOMAIN_ID`` and take each other's samples. The id comes from
:func:`brake_hil.app.chain_environment.choose_domain_id` (a lock file per id, held while this
process lives); tests that want one of their own per test call
:func:`test.nodes.harness.unique_domain_id`, which holds another. DDS stays on loopback
(``test/conftest.py``).
"""

from __future__ import annotations

import os

from brake_hil.app.chain_environment import choose_domain_id

os.environ["ROS_DOMAIN_ID"] = str(choose_domain_id())
