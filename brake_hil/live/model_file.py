"""Model files: what the live caliper model runs, loaded from a file (ROS-free).

A model file names the model the ``caliper_model`` node steps and ``brake-hil regress``
replays. One loader per file kind, chosen by suffix, behind one small interface: a loader
takes the path and the operating mean master-cylinder pressure and returns a
:class:`LiveModel`, which makes fresh per-sample steppers and runs the same model offline
in batch (so a live run can be checked sample for sample).

Kinds today:

* ``.yaml`` / ``.yml``: a rig file (interface.md), with its optional ``model:`` overrides
  (``k_eh``, ``c_eh``, ``C_b``, ``R_v``, ...), which :func:`derive_parameters` applies: the
  seed's LTI model (eq. 21c-f) at ``mean_pressure``.

* ``.json``: the improved model ``brake-hil diagnose`` writes (the calibrated LTI model with
  the effects it found, :mod:`brake_hil.diagnosis.improved_model`), stepped by the same
  integrator the diagnosis fitted it with.
"""

from __future__ import annotations

from pathlib import Path

from brake_hil.errors import ModelFileError
from brake_hil.files import RIG_FILE_MAX_BYTES, check_input_file
from brake_hil.live.improved import load_improved_model
from brake_hil.live.model import LiveModel, ModelLoader
from brake_hil.physics.lti_model import (
    CaliperStepper,
    DiscreteModel,
    caliper_state_space,
    discretize,
    simulate,
)
from brake_hil.physics.parameters import DEFAULT_MEAN_PRESSURE, ModelParameters, derive_parameters
from brake_hil.physics.rig import load_rig
from brake_hil.types import FloatArray


def lti_model(
    parameters: ModelParameters, path: Path, description: str, mean_pressure: float
) -> LiveModel:
    """The seed's LTI model (eq. 21c-f) with ``parameters``, exactly discretised at 1 kHz."""
    discrete: DiscreteModel = discretize(caliper_state_space(parameters))

    def batch(pressure: FloatArray) -> FloatArray:
        return simulate(discrete, pressure)

    return LiveModel(
        path=path,
        description=description,
        mean_pressure=mean_pressure,
        stepper=lambda: CaliperStepper(discrete),
        batch=batch,
        parameters=parameters,
    )


def load_rig_model(path: Path, mean_pressure: float) -> LiveModel:
    """A rig file's LTI model at ``mean_pressure`` (Pa), its ``model:`` overrides applied."""
    rig = load_rig(path)
    description = f"LTI model of {rig.name} at mean p_i {mean_pressure / 1e6:.3g} MPa"
    if rig.model_overrides:
        description += f" (overrides: {', '.join(sorted(rig.model_overrides))})"
    return lti_model(derive_parameters(rig, mean_pressure), path, description, mean_pressure)


_LOADERS: dict[str, ModelLoader] = {
    ".yaml": load_rig_model,
    ".yml": load_rig_model,
    ".json": load_improved_model,
}


def register_loader(suffix: str, loader: ModelLoader) -> None:
    """Read model files ending in ``suffix`` (e.g. ``".json"``) with ``loader``."""
    _LOADERS[suffix.lower()] = loader


def model_kinds() -> tuple[str, ...]:
    """The suffixes a model file may have."""
    return tuple(sorted(_LOADERS))


def load_model(path: Path | str, mean_pressure: float = DEFAULT_MEAN_PRESSURE) -> LiveModel:
    """The model in ``path``, derived at ``mean_pressure`` (Pa) where it depends on it.

    Raises:
        ModelFileError: no such file, not a regular file, larger than
            :data:`~brake_hil.files.RIG_FILE_MAX_BYTES`, or a suffix no loader reads.
        RigError: a rig file that is not UTF-8, not strict YAML, or has a bad key or value
            (names the file and key).
        ImprovedModelError: an improved model that is not strict JSON (no NaN) or is
            malformed.
    """
    path = Path(path)
    check_input_file(path, "model file", RIG_FILE_MAX_BYTES, ModelFileError)
    if not mean_pressure > 0.0:
        raise ModelFileError(f"{path}: mean pressure must be positive, got {mean_pressure} Pa")
    loader = _LOADERS.get(path.suffix.lower())
    if loader is None:
        kinds = ", ".join(model_kinds())
        raise ModelFileError(f"{path}: unknown model file kind {path.suffix!r} (known: {kinds})")
    return loader(path, mean_pressure)
