"""Canonical matrices of the Whipple model with σ, from a parameter set.

Two conventions for the σ of the matrix entries:

* ``correlated`` (default): the full parameter covariance (from the raw readings) is carried
  through, ``Σ_K = J Σ_p Jᵀ``; parameters that share readings (r_R in x_B, z_B and I_Byy, say)
  are correlated and their errors partly cancel or add.
* ``paper``: the paper's Table 3 treated the 25 parameters as independent, ``Σ_K = J diag(σ_p²)
  Jᵀ``. ``test/core/test_paper_tables.py`` shows this reproduces Table 3 and documents where the
  correlated σ differ.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..benchmark import PARAMETER_NAMES, ParameterSet
from ..whipple import WhippleMatrices, canonical_matrices
from .uncertain import UncertainVector, complex_step_jacobian

__all__ = ["MATRIX_NAMES", "MatrixSet", "SigmaConvention", "canonical_with_sigma", "coefficient_names"]

MATRIX_NAMES: tuple[str, ...] = ("M", "C1", "K0", "K2")


class SigmaConvention(str, Enum):
    """How parameter correlations enter the matrix σ."""

    CORRELATED = "correlated"
    PAPER = "paper"


def coefficient_names() -> tuple[str, ...]:
    """Entry names ``M11 … K2_22`` (row roll/steer, column roll/steer, 1-based)."""
    out = []
    for name in MATRIX_NAMES:
        sep = "" if name == "M" else "_"
        out += [f"{name}{sep}{i}{j}" for i in (1, 2) for j in (1, 2)]
    return tuple(out)


def _flat(p: Any) -> dict[str, Any]:
    cm = canonical_matrices(p)
    out = {}
    names = iter(coefficient_names())
    for mat in (cm.M, cm.C1, cm.K0, cm.K2):
        for i in range(2):
            for j in range(2):
                out[next(names)] = mat[..., i, j]
    return out


@dataclass(frozen=True)
class MatrixSet:
    """Canonical matrices with σ.

    Attributes:
        matrices: The values.
        sigma: σ of every entry, same layout (a :class:`WhippleMatrices` of σ).
        coefficients: All 16 entries with their covariance (names from
            :func:`coefficient_names`).
        convention: How the σ were computed.
        g: Gravity used with K0, m/s².
    """

    matrices: WhippleMatrices
    sigma: WhippleMatrices
    coefficients: UncertainVector
    convention: SigmaConvention
    g: float


def _as_matrices(v: NDArray[np.float64]) -> WhippleMatrices:
    m = v.reshape(4, 2, 2)
    return WhippleMatrices(M=m[0], C1=m[1], K0=m[2], K2=m[3])


def canonical_with_sigma(ps: ParameterSet, convention: SigmaConvention = SigmaConvention.CORRELATED) -> MatrixSet:
    """Canonical matrices M, C1, K0, K2 of ``ps`` with the σ of every entry."""
    prop = complex_step_jacobian(_flat, ps.parameters.as_dict(), PARAMETER_NAMES, coefficient_names())
    pv = ps.parameters if convention is SigmaConvention.CORRELATED else ps.parameters.independent()
    coeffs = prop.with_covariance(pv.covariance)
    return MatrixSet(
        _as_matrices(coeffs.values),
        _as_matrices(coeffs.sigmas),
        coeffs,
        convention,
        ps.parameters.value("g"),
    )
