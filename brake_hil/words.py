"""Plain words shared by every command's output."""

from __future__ import annotations

import math

__all__ = ["counted", "energy_share", "noise_times"]


def counted(count: int, noun: str) -> str:
    """``1 run``, ``5 runs``: a count with its noun, plural unless one (an ``s`` added)."""
    return f"{count} {noun}{'' if count == 1 else 's'}"


def noise_times(squared_ratio: float) -> str:
    """``21 times the sensor noise (RMS)``, from a ratio of mean squares to the noise's."""
    rms = math.sqrt(max(squared_ratio, 0.0))
    times = f"{rms:.0f}" if rms >= 10 else f"{rms:.1f}"
    return f"{times} times the sensor noise (RMS)"


def energy_share(percent: float) -> str:
    """A share of a signal's energy: ``0.12 %``, ``0.0082 %``, or ``under 0.0001 %``."""
    if abs(percent) < 1e-4:
        return "under 0.0001 %"
    return f"{percent:.2f} %" if abs(percent) >= 0.01 else f"{percent:.2g} %"
