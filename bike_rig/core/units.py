"""Unit conversions at the input boundary (degrees appear only in input files)."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["DEGREE", "radians"]

#: One degree in radians.
DEGREE = np.pi / 180.0


def radians(degrees: Any) -> Any:
    """Convert an angle read in degrees to radians (broadcasting, complex-step safe)."""
    return degrees * DEGREE
