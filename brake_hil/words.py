"""Plain words shared by every command's output."""

from __future__ import annotations

__all__ = ["counted"]


def counted(count: int, noun: str) -> str:
    """``1 run``, ``5 runs``: a count with its noun, plural unless one (an ``s`` added)."""
    return f"{count} {noun}{'' if count == 1 else 's'}"
