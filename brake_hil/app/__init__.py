"""The application layer: one module per command, each a function that returns a result.

``brake-hil``'s commands (:mod:`.compare`, :mod:`.characterize`, :mod:`.diagnose`,
:mod:`.simulate`, :mod:`.cases`, :mod:`.benchmark`, :mod:`.regress`, :mod:`.recover`,
:mod:`.diagnose_many`, :mod:`.fleet`, :mod:`.trend`) and the
node-chain launcher (:mod:`.chain`) do their work and write their output files here, and
print nothing; :mod:`brake_hil.cli` parses, prints and sets exit codes. Work over many
recordings goes through :func:`.parallel.parallel_map`, the one place Dask is called.
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
    "diagnose_many",
    "fleet",
    "naming",
    "parallel",
    "recordings",
    "recover",
    "regress",
    "simulate",
    "trend",
]
