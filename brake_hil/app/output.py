"""Writing a command's JSON result file (shared by the commands that take ``--json``)."""

from __future__ import annotations

import json
from pathlib import Path

__all__ = ["write_json"]


def write_json(path: Path | None, document: object) -> Path | None:
    """Write ``document`` as indented JSON to ``path`` (its folder made); ``None``: nothing.

    Args:
        path: the file to write, or ``None``.
        document: JSON-ready data.

    Returns:
        ``path``.
    """
    if path is None:
        return None
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
    return path
