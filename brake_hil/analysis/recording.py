"""A recording as aligned arrays: what the readers produce and the analyses consume."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from brake_hil.types import FloatArray


@dataclass(frozen=True)
class Recording:
    """Samples of one rig run on the master-cylinder pressure's time base.

    ``time`` is seconds since the first ``p_i`` sample; ``start_stamp_ns`` is that first
    sample's ``header.stamp`` in nanoseconds. Every other channel is aligned to ``time``
    (exact when stamps coincide, as the contract asks; linearly interpolated otherwise).
    Channels absent from the recording are ``None``.
    """

    path: Path
    time: FloatArray  # s
    master_cylinder_pressure: FloatArray  # p_i, Pa (gauge)
    bore_pressure: FloatArray | None = None  # p_b, Pa
    block_force: FloatArray | None = None  # F_k, N
    caliper_displacement: FloatArray | None = None  # x_c, m (negative under load)
    air_pressure: FloatArray | None = None  # p_a, Pa
    predicted_bore_pressure: FloatArray | None = None  # Pa
    predicted_block_force: FloatArray | None = None  # N
    predicted_caliper_displacement: FloatArray | None = None  # m
    start_stamp_ns: int = 0
    topics: tuple[str, ...] = field(default=())  # every topic the file holds

    @property
    def sample_rate(self) -> float:
        """Median sample rate of ``p_i`` (Hz)."""
        return float(1.0 / np.median(np.diff(self.time)))

    def measured(self) -> dict[str, FloatArray | None]:
        """Measured outputs keyed ``p_b``, ``F_k``, ``x_c``."""
        return {
            "p_b": self.bore_pressure,
            "F_k": self.block_force,
            "x_c": self.caliper_displacement,
        }
