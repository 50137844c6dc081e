"""Monte Carlo σ of a model eigenvalue, for speeds where its first-order σ is not defined.

Near a branch point (two real roots merging into a complex pair) the first-order σ of
:func:`bike_rig.core.uncertainty.eigen_sigma.eigenvalues_with_sigma` is withheld (NaN), yet the
spread of the eigenvalue over the parameters' uncertainty stays finite. As
:mod:`bike_rig.core.uncertainty.speed_mc` does for the critical speeds, the 26 parameters are
drawn from their covariance (multivariate normal; a feedback's gain values given with σ are
drawn too, independently), the canonical matrices of all draws are computed at once
(:func:`bike_rig.core.whipple.canonical_matrices`), and at each speed every draw's eigenvalue
nearest to the nominal one is taken; its σ is the robust standard deviation (half the
15.87–84.13 % percentile range, σ for a normal spread, blind to the few draws that jump to
another root). Units: speeds m/s, eigenvalues and σ 1/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..benchmark import ParameterSet
from ..feedback import Feedback
from ..symbols import PARAMETER_NAMES
from ..uncertainty.matrix_sigma import SigmaConvention
from ..whipple import canonical_matrices, state_space
from ..whipple.closed_loop import closed_loop_state_space

__all__ = ["DEFAULT_DRAWS", "EigenvalueDraws", "eigenvalue_monte_carlo"]

FloatArray = NDArray[np.float64]

#: Draws by default: the relative standard error of a robust σ is about 1.7/sqrt(2 N), 2.7 % for 2000.
DEFAULT_DRAWS = 2000
#: The percentiles whose half-range is the robust σ [%].
_PERCENTILES = (15.865525393145708, 84.13447460685429)
#: A draw's eigenvalue with a smaller |Im| [1/s] is real.
_REAL = 1e-9


@dataclass(frozen=True)
class EigenvalueDraws:
    """The Monte Carlo spread of eigenvalues at several speeds.

    Attributes:
        real_sigma: Robust σ of Re λ at each speed [1/s].
        imag_sigma: Robust σ of Im λ at each speed [1/s].
        real_fraction: Share of the draws whose eigenvalue is real there (the pair broke up) [-].
        draws: Number of draws.
    """

    real_sigma: FloatArray
    imag_sigma: FloatArray
    real_fraction: FloatArray
    draws: int


def _robust_sigma(x: FloatArray) -> float:
    lo, hi = np.percentile(x, _PERCENTILES)
    return 0.5 * float(hi - lo)


def eigenvalue_monte_carlo(
    ps: ParameterSet,
    speeds: ArrayLike,
    nominal: ArrayLike,
    feedback: Feedback | None = None,
    convention: SigmaConvention | str = SigmaConvention.CORRELATED,
    draws: int = DEFAULT_DRAWS,
    seed: int = 0,
) -> EigenvalueDraws:
    """The σ of the eigenvalue nearest ``nominal`` at each of ``speeds``, by drawing the parameters.

    Args:
        ps: The parameter set (values and covariance), with the rider added.
        speeds: m/s, shape (K,).
        nominal: The nominal eigenvalue at each speed [1/s], complex, shape (K,).
        feedback: The closed loop's feedback (its gain values given with σ are drawn too), or None.
        convention: ``correlated`` (full covariance) or ``paper`` (parameters independent).
        draws: Number of draws (at least 2).
        seed: Seed of the random generator (reproducible).

    Raises:
        ValueError: Fewer than 2 draws, or speeds and nominal eigenvalues of different lengths.
        ModelError: A draw with a singular mass matrix.
    """
    v = np.atleast_1d(np.asarray(speeds, dtype=float))
    lam0 = np.atleast_1d(np.asarray(nominal, dtype=complex))
    if draws < 2 or v.shape != lam0.shape:
        raise ValueError(f"{draws} draws for {v.size} speeds and {lam0.size} eigenvalues")
    pv = ps.parameters if SigmaConvention(convention) is SigmaConvention.CORRELATED else ps.parameters.independent()
    rng = np.random.default_rng(seed)
    x = rng.multivariate_normal(
        np.asarray(pv.values, dtype=float),
        np.asarray(pv.covariance, dtype=float),
        size=draws,
        method="eigh",
        check_valid="ignore",
    )
    params = {n: x[:, pv.index(n)] for n in PARAMETER_NAMES}
    mats, g = canonical_matrices(params), params["g"][:, None, None]
    knots = () if feedback is None else feedback.uncertain_knots()
    dk = rng.standard_normal((draws, len(knots))) * np.array([k[2] for k in knots])
    out = np.full((3, v.size), np.nan)
    for i, (speed, target) in enumerate(zip(v, lam0, strict=True)):
        if not np.isfinite(target):
            continue
        if feedback is None:
            a, _ = state_space(mats, speed, g)
        else:
            gains = feedback.gains(speed) + dk @ feedback.knot_jacobian(speed)  # (draws, 4)
            a, _ = closed_loop_state_space(mats, speed, g, gains)
        lam = np.linalg.eigvals(np.asarray(a, dtype=float))  # (draws, 4)
        pick = lam[np.arange(draws), np.argmin(np.abs(lam - target), axis=1)]
        out[:, i] = _robust_sigma(pick.real), _robust_sigma(np.abs(pick.imag)), np.mean(np.abs(pick.imag) < _REAL)
    return EigenvalueDraws(out[0], out[1], out[2], draws)
