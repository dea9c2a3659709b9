"""Reports for people: plots of measured against predicted, residuals, hysteresis loops."""

from __future__ import annotations

__all__ = [
    "diagnosis_report",
    "plots",
    "trend_report",
]
