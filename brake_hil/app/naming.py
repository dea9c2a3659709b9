"""Errors of an analysis named after the recording it ran on (one line, exit 2).

The analyses check their inputs at the doors; what they still find (a channel without
motion at the excitation frequency, a segment too short) is a
:class:`~brake_hil.errors.BrakeHilError` that may not name the file. A numerical failure the
doors did not foresee (a division by zero, a singular matrix, a fit whose residuals are not
finite) is turned into a :class:`~brake_hil.errors.SignalError` rather than a traceback.
"""

from __future__ import annotations

from collections.abc import Iterator
import contextlib
from pathlib import Path

import numpy as np

from brake_hil.errors import BrakeHilError, SignalError

__all__ = ["naming"]


@contextlib.contextmanager
def naming(path: Path) -> Iterator[None]:
    """Give every error raised inside a message that starts with ``path``.

    Raises:
        BrakeHilError: the same type, its message prefixed with ``path`` when it lacked it.
        SignalError: for an arithmetic, linear-algebra or value error of the analysis.
    """
    try:
        yield
    except BrakeHilError as err:
        if str(err).startswith(str(path)):
            raise
        raise type(err)(f"{path}: {err}") from err
    except (ArithmeticError, np.linalg.LinAlgError, ValueError) as err:
        problem = " ".join(str(err).split()) or type(err).__name__
        raise SignalError(
            f"{path}: the analysis failed on this recording ({type(err).__name__}: {problem})"
        ) from err
