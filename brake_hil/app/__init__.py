"""The application layer: one module per command, each a function that returns a result.

``brake-hil``'s commands (:mod:`.compare`, :mod:`.characterize`, :mod:`.diagnose`,
:mod:`.simulate`, :mod:`.cases`, :mod:`.benchmark`, :mod:`.regress`, :mod:`.recover`) and the
node-chain launcher (:mod:`.chain`) do their work and write their output files here, and
print nothing; :mod:`brake_hil.cli` parses, prints and sets exit codes. Work over many
recordings goes through :func:`.parallel.parallel_map`, the one place a process pool is made.
No rclpy.
"""

from __future__ import annotations

__all__ = [
    "benchmark",
    "cases",
    "chain",
    "characterize",
    "compare",
    "diagnose",
    "naming",
    "parallel",
    "recover",
    "regress",
    "simulate",
]
