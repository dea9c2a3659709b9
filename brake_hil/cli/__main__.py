"""``python -m brake_hil.cli``: the ``brake-hil`` command line."""

from __future__ import annotations

import sys

from brake_hil.cli import main

if __name__ == "__main__":
    sys.exit(main())
