"""The improved model the diagnosis found: saved as JSON, loaded to run live or in batch.

``improved_model.json`` names the rig file, the calibration's multipliers, the effects with
their fitted parameters, and what the candidates need to know of the recording (the flow
scale of the orifice term, the time at which a drift is zero, the pressure span of the
entrained-air schedule). ``brake_hil.live.improved.load_improved_model`` turns it back into a
:class:`~brake_hil.live.model_file.LiveModel`: a per-sample stepper for the 1 kHz
caliper-model node and a batch run of the same model, which agree sample for sample.
"""

from __future__ import annotations

from dataclasses import dataclass
import json
from pathlib import Path

import numpy as np

from brake_hil.diagnosis.calibration import apply_multipliers
from brake_hil.diagnosis.candidates import CANDIDATES, candidate
from brake_hil.diagnosis.candidates.base import Draft, rig_context
from brake_hil.diagnosis.engine import ModelSpec
from brake_hil.errors import ImprovedModelError
from brake_hil.files import load_json
from brake_hil.physics.rig import Rig

FORMAT = "brake_hil/improved_model/1"
LIVE_SAMPLE_TIME = 1.0e-3


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
            model = candidate(name)
            theta = np.array([[self.parameters[p.name] for p in model.parameters]])
            model.fill(draft, theta, context)
        return draft.spec()


def read_improved_model(path: Path) -> ImprovedModel:
    """Read ``improved_model.json``; refuse a malformed one naming the file and the key."""
    document = load_json(path, "improved model", ImprovedModelError)
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise ImprovedModelError(f"{path}: not an improved model (format {FORMAT} expected)")
    try:
        effects = tuple(document["effects"])
        known = {c.name for c in CANDIDATES}
        unknown = [e for e in effects if e not in known]
        if unknown:
            raise ImprovedModelError(f"{path}: unknown effect '{unknown[0]}'")
        parameters = {str(k): float(v) for k, v in document["parameters"].items()}
        for name in effects:
            model = candidate(name)
            retired = [p for p in model.retired_parameters if p in parameters]
            if retired:
                raise ImprovedModelError(
                    f"{path}: '{retired[0]}' of {name} is from an older law of that effect;"
                    " diagnose the recording again to write a current model"
                )
            for parameter in model.parameters:
                if parameter.name not in parameters and parameter.absent is not None:
                    parameters[parameter.name] = parameter.absent  # an older file's model
                elif parameter.name not in parameters:
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
