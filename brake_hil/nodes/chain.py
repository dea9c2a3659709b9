"""``python -m brake_hil.nodes.chain``: the node-chain launcher.

The launcher is no node: it starts the nodes as processes (:mod:`brake_hil.app.chain`);
its command line is :mod:`brake_hil.cli.chain`. This module only keeps the documented
``python -m`` entry.
"""

from __future__ import annotations

import sys

from brake_hil.cli.chain import main

if __name__ == "__main__":
    sys.exit(main())
