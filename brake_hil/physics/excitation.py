"""Excitation profiles like the seed's: ramp to a maximum pressure, then 5 Hz pulsing.

The seed's rig ramps the master-cylinder pressure up, then a 3-way solenoid pulses the air
at 5 Hz; a run may hold several maximum pressures (1.38, 2.07, 2.76 MPa). The pulsing here
is a sine about ``max_pressure - amplitude`` with ``amplitude = amplitude_fraction *
max_pressure`` (0.22 gives the seed's ~0.6 MPa peak-to-peak at 1.38 MPa).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from brake_hil.types import FloatArray

SEED_MAX_PRESSURES = (1.38e6, 2.07e6, 2.76e6)
"""Maximum master-cylinder pressures of the seed's experiments (Pa)."""


def pulsing_profile(
    max_pressures: Sequence[float] = (1.38e6,),
    sample_rate_hz: float = 1000.0,
    ramp_s: float = 1.0,
    pulsing_s: float = 5.0,
    pulsing_hz: float = 5.0,
    amplitude_fraction: float = 0.22,
) -> tuple[FloatArray, FloatArray]:
    """Time (s) and master-cylinder pressure (Pa) of ramp-then-pulse segments in a row.

    Each segment ramps from the previous level to its pulsing mean over ``ramp_s``, then
    pulses for ``pulsing_s``. The first segment starts from zero gauge pressure.
    """
    pieces: list[FloatArray] = []
    level = 0.0
    ramp = np.arange(int(round(ramp_s * sample_rate_hz))) / sample_rate_hz
    pulse = np.arange(int(round(pulsing_s * sample_rate_hz))) / sample_rate_hz
    for max_pressure in max_pressures:
        amplitude = amplitude_fraction * max_pressure
        mean = max_pressure - amplitude
        shape = 0.5 - 0.5 * np.cos(np.pi * ramp / ramp_s)  # smooth start and end
        pieces.append(level + (mean - level) * shape)
        pieces.append(mean + amplitude * np.sin(2.0 * np.pi * pulsing_hz * pulse))
        level = mean
    pressure = np.concatenate(pieces)
    return np.arange(pressure.size) / sample_rate_hz, pressure
