"""The improved model of ``brake-hil diagnose`` run live (sample by sample) and in batch."""

from __future__ import annotations

from collections import deque
from pathlib import Path

import numpy as np

from brake_hil.diagnosis.engine import ChannelDelay, Integrator, ModelSpec, simulate_batch
from brake_hil.diagnosis.improved_model import LIVE_SAMPLE_TIME, read_improved_model
from brake_hil.live.model import LiveModel
from brake_hil.physics.lti_model import ModelOutput
from brake_hil.physics.rig import load_rig
from brake_hil.types import FloatArray


class CandidateStepper:
    """One improved model stepped live, sample by sample (the caliper node's interface).

    The first call starts from the equilibrium at its input, as the batch run does. A sensor
    delay is applied to the outputs from a short history (linear interpolation); a negative
    delay (the input acquired late) cannot be undone live and is applied as zero.
    """

    def __init__(
        self, spec: ModelSpec, pressure_ceiling: float, sample_time: float = LIVE_SAMPLE_TIME
    ) -> None:
        self._spec = spec
        self._ceiling = pressure_ceiling
        self._sample_time = sample_time
        self._integrator: Integrator | None = None
        self._previous = 0.0
        delay = spec.term(ChannelDelay)
        delays = np.zeros(3) if delay is None else np.maximum(delay.delays[0], 0.0)
        self._delay_samples = delays / sample_time
        self._history: deque[FloatArray] = deque(
            maxlen=int(np.ceil(self._delay_samples.max())) + 2
        )

    def step(self, pressure: float) -> ModelOutput:
        """Advance one sample with the new input ``pressure`` (Pa)."""
        if self._integrator is None:
            self._integrator = Integrator(
                self._spec, pressure, self._sample_time, self._ceiling, duration=3600.0
            )
            outputs = self._integrator.outputs()[0]
        else:
            outputs = self._integrator.advance(self._previous, pressure)[0]
        self._previous = pressure
        self._history.append(outputs)
        return ModelOutput(*self._delayed())

    def _delayed(self) -> list[float]:
        history = list(self._history)
        result = []
        for channel, delay in enumerate(self._delay_samples):
            position = len(history) - 1 - delay
            low = int(np.floor(max(position, 0.0)))
            high = min(low + 1, len(history) - 1)
            weight = max(position, 0.0) - low
            value = (1 - weight) * history[low][channel] + weight * history[high][channel]
            result.append(float(value))
        return result


def load_improved_model(path: Path, mean_pressure: float) -> LiveModel:
    """A :class:`~brake_hil.live.model_file.LiveModel` of an ``improved_model.json``."""
    model = read_improved_model(path)
    rig = load_rig(model.rig_path)
    spec = model.spec(rig, mean_pressure)

    def batch(pressure: FloatArray) -> FloatArray:
        outputs = simulate_batch(
            spec, pressure, LIVE_SAMPLE_TIME, pressure_ceiling=model.pressure_ceiling
        )
        return np.asarray(outputs[0], dtype=float)

    effects = ", ".join(model.effects) or "none"
    return LiveModel(
        path=path,
        description=f"improved model ({effects}) on {model.rig_path.name}",
        mean_pressure=mean_pressure,
        stepper=lambda: CandidateStepper(spec, model.pressure_ceiling),
        batch=batch,
        parameters=spec.params[0],
    )
