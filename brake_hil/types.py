"""Array aliases, the only place they are defined (units stated where each is used)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
"""A float64 array (units stated where it is used)."""
IntArray = npt.NDArray[np.int64]
"""An int64 array (ns stamps, counts)."""
IndexArray = npt.NDArray[np.intp]
"""Indices into another array."""
BoolArray = npt.NDArray[np.bool_]
"""A mask."""
ByteArray = npt.NDArray[np.uint8]
"""Raw bytes (CDR payloads)."""

__all__ = ["BoolArray", "ByteArray", "FloatArray", "IndexArray", "IntArray"]
