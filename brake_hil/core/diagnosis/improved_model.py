"""The improved model the diagnosis found: saved as JSON, loaded to run live or in batch.

``improved_model.json`` names the rig file, the calibration's multipliers, the effects with
their fitted parameters, and what the candidates need to know of the recording (the flow
scale of the orifice term, the time at which a drift is zero, the pressure span of the
entrained-air schedule). :func:`load_improved_model` turns it back into a
:class:`~brake_hil.core.model_file.LiveModel`: a per-sample stepper for the 1 kHz
caliper-model node and a batch run of the same model, which agree sample for sample.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
import json
from pathlib import Path

import numpy as np

from brake_hil.core.diagnosis.calibration import apply_multipliers
from brake_hil.core.diagnosis.candidates import BY_NAME
from brake_hil.core.diagnosis.candidates.base import Draft, rig_context
from brake_hil.core.diagnosis.engine import (
    Integrator,
    ModelSpec,
    simulate_batch,
)
from brake_hil.core.lti_model import ModelOutput
from brake_hil.core.model_file import LiveModel
from brake_hil.core.rig import Rig, load_rig
from brake_hil.core.types import FloatArray
from brake_hil.errors import BrakeHilError

FORMAT = "brake_hil/improved_model/1"
LIVE_SAMPLE_TIME = 1.0e-3


class ImprovedModelError(BrakeHilError, ValueError):
    """An improved-model file is missing, malformed or names an unknown effect."""


@dataclass(frozen=True)
class ImprovedModel:
    """What ``improved_model.json`` holds."""

    rig_path: Path
    multipliers: dict[str, float]
    effects: tuple[str, ...]
    parameters: dict[str, float]  # the effects' own parameters by name
    flow_amplitude: float  # m^3/s
    time_reference: float  # s
    pressure_ceiling: float  # Pa

    def as_dict(self) -> dict[str, object]:
        """JSON form."""
        return {
            "format": FORMAT,
            "rig": str(self.rig_path),
            "calibration": self.multipliers,
            "effects": list(self.effects),
            "parameters": self.parameters,
            "context": {
                "flow_amplitude": self.flow_amplitude,
                "time_reference": self.time_reference,
                "pressure_ceiling": self.pressure_ceiling,
            },
        }

    def save(self, path: Path) -> Path:
        """Write the JSON file."""
        path.write_text(json.dumps(self.as_dict(), indent=2) + "\n", encoding="utf-8")
        return path

    def spec(self, rig: Rig, mean_pressure: float) -> ModelSpec:
        """The simulator spec (one set) of this model at a mean pressure (Pa)."""
        context = rig_context(rig, self.flow_amplitude, self.time_reference)
        draft = Draft([apply_multipliers(rig, mean_pressure, self.multipliers)])
        for name in self.effects:
            candidate = BY_NAME[name]
            theta = np.array([[self.parameters[p.name] for p in candidate.parameters]])
            candidate.fill(draft, theta, context)
        return ModelSpec(tuple(draft.params), **draft.fields)  # type: ignore[arg-type]


def read_improved_model(path: Path) -> ImprovedModel:
    """Read ``improved_model.json``; refuse a malformed one naming the file and the key."""
    try:
        document = json.loads(path.read_text(encoding="utf-8"))
    except OSError as err:
        raise ImprovedModelError(f"{path}: cannot read: {err.strerror or err}") from err
    except json.JSONDecodeError as err:
        raise ImprovedModelError(f"{path}: not valid JSON: {err.msg}") from err
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise ImprovedModelError(f"{path}: not an improved model (format {FORMAT} expected)")
    try:
        effects = tuple(document["effects"])
        unknown = [e for e in effects if e not in BY_NAME]
        if unknown:
            raise ImprovedModelError(f"{path}: unknown effect '{unknown[0]}'")
        parameters = {str(k): float(v) for k, v in document["parameters"].items()}
        for name in effects:
            for parameter in BY_NAME[name].parameters:
                if parameter.name not in parameters:
                    raise ImprovedModelError(
                        f"{path}: missing parameter '{parameter.name}' of {name}"
                    )
        rig_path = Path(document["rig"])
        if not rig_path.is_absolute():
            rig_path = (path.parent / rig_path).resolve()
        context = document["context"]
        return ImprovedModel(
            rig_path=rig_path,
            multipliers={str(k): float(v) for k, v in document["calibration"].items()},
            effects=effects,
            parameters=parameters,
            flow_amplitude=float(context["flow_amplitude"]),
            time_reference=float(context["time_reference"]),
            pressure_ceiling=float(context["pressure_ceiling"]),
        )
    except (KeyError, TypeError, ValueError) as err:
        if isinstance(err, ImprovedModelError):
            raise
        raise ImprovedModelError(f"{path}: malformed improved model: {err}") from err


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
        delays = (
            np.zeros(3) if spec.output_delay is None else np.maximum(spec.output_delay[0], 0.0)
        )
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
    """A :class:`~brake_hil.core.model_file.LiveModel` of an ``improved_model.json``."""
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
