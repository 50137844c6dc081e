"""Monte Carlo check of the weave and capsize speeds and their linear σ.

The linear σ (:mod:`bike_rig.core.uncertainty.speed_sigma`) is first order; this module draws
the inputs, evaluates the whole chain on every draw and compares the spread:
:func:`speed_monte_carlo` from the raw readings (independent normal draws, so the parameter
formulas' non-linearity counts too), :func:`speed_monte_carlo_from_parameters` from a parameter
set's covariance (multivariate normal). A rider may be added to every draw (a Yeadon rider's σ
drawn linearly). :func:`critical_speeds_batch` is a vectorised
:func:`bike_rig.core.whipple.critical_speeds` (checked draw by draw in
``test/core/test_speed_mc.py``). Speeds and σ in m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..benchmark import ComMethod, ParameterSet, compute_parameters, monte_carlo_parameters
from ..errors import BikeRigError
from ..measurements import Measurements
from ..rider import Rider, add_rider, combine_rear_frame_values, rider_draws
from ..symbols import PARAMETER_NAMES
from ..whipple import (
    WhippleMatrices,
    canonical_matrices,
    characteristic_polynomial,
    hurwitz_determinant,
    hurwitz_quadratic,
    pair_crossing_rate,
)
from .speed_sigma import SpeedWithSigma, critical_speeds_with_sigma

__all__ = [
    "DEFAULT_SAMPLES",
    "MonteCarloError",
    "SpeedDraws",
    "SpeedMonteCarlo",
    "critical_speeds_batch",
    "speed_monte_carlo",
    "speed_monte_carlo_from_parameters",
]

FloatArray = NDArray[np.float64]

#: Default number of draws: the relative standard error of a sample σ is about
#: 1/sqrt(2 N), 1.1 % for 4000 draws.
DEFAULT_SAMPLES = 4000

#: Newton steps polishing the closed-form candidates (quadratic convergence from a candidate
#: that is already accurate to a few ulp of the expanded polynomial).
_NEWTON_STEPS = 6


class MonteCarloError(BikeRigError):
    """A Monte Carlo run was asked for with impossible settings (e.g. fewer than 2 draws)."""


@dataclass(frozen=True)
class SpeedDraws:
    """One critical speed over the Monte Carlo draws, with its linear counterpart.

    Attributes:
        name: ``"weave speed"`` or ``"capsize speed"``.
        draws: The speed of every draw, m/s; NaN where that draw has no such speed.
        mean: Mean of the draws that have the speed, m/s (NaN if fewer than 2).
        std: Their sample standard deviation (ddof = 1), m/s (NaN if fewer than 2).
        robust_std: Half the 15.87–84.13 % percentile range, m/s: equals σ for a normal
            distribution and ignores a few outlying draws.
        missing: Number of draws without this speed.
        linear: The speed of the nominal inputs, m/s, or None when it has none.
        linear_sigma: Its first-order σ (full covariance), m/s, or None.
    """

    name: str
    draws: FloatArray
    mean: float
    std: float
    robust_std: float
    missing: int
    linear: float | None
    linear_sigma: float | None

    @property
    def ratio(self) -> float:
        """``std / linear_sigma`` (NaN when either is missing or the linear σ is 0)."""
        if self.linear_sigma is None or not self.linear_sigma > 0 or not math.isfinite(self.std):
            return math.nan
        return self.std / self.linear_sigma


@dataclass(frozen=True)
class SpeedMonteCarlo:
    """Monte Carlo of the critical speeds of one bicycle.

    Attributes:
        bicycle: The bicycle's name (with the rider's when one was added).
        input_kind: ``"raw readings"`` or ``"parameters"``: what was drawn.
        samples: Number of draws.
        seed: Seed of the random generator.
        weave: The weave speed over the draws.
        capsize: The capsize speed over the draws.
    """

    bicycle: str
    input_kind: str
    samples: int
    seed: int
    weave: SpeedDraws
    capsize: SpeedDraws


def _quadratic_roots(c2: FloatArray, c1: FloatArray, c0: FloatArray) -> FloatArray:
    """Real roots of ``c2 x² + c1 x + c0`` per row, shape (N, 2), NaN where absent.

    Element-wise the same as ``whipple.stability._quadratic_real_roots`` (cancellation-free; the degree
    drops where ``c2 = 0``).
    """
    out = np.full(c2.shape + (2,), np.nan)
    lin = c2 == 0.0
    ok = lin & (c1 != 0.0)
    out[ok, 0] = -c0[ok] / c1[ok]
    disc = c1 * c1 - 4.0 * c2 * c0
    quad = ~lin & (disc >= 0.0)
    big = -0.5 * (c1 + np.copysign(np.sqrt(np.where(quad, disc, 0.0)), c1))
    nz = quad & (big != 0.0)
    out[nz, 0] = big[nz] / c2[nz]
    out[nz, 1] = c0[nz] / big[nz]
    out[quad & (big == 0.0), 0] = 0.0
    return out


def _a(coef: FloatArray, v: FloatArray) -> tuple[list[FloatArray], list[FloatArray]]:
    """``a_k(v)`` and ``d a_k/dv`` (k = 0..4) for coefficients (N, 5, 5) and speeds (N, K)."""
    powers = np.stack([np.ones_like(v), v, v**2, v**3, v**4], axis=-1)  # (N, K, 5)
    dpowers = np.stack([np.zeros_like(v), np.ones_like(v), 2 * v, 3 * v**2, 4 * v**3], axis=-1)
    a = np.einsum("nkj,nmj->nmk", coef, powers)  # (N, K, 5): a_k at each candidate
    da = np.einsum("nkj,nmj->nmk", coef, dpowers)
    return [a[..., k] for k in range(5)], [da[..., k] for k in range(5)]


def _polish(coef: FloatArray, v: FloatArray, oscillatory: bool) -> FloatArray:
    for _ in range(_NEWTON_STEPS):
        a, da = _a(coef, v)
        f, df = hurwitz_determinant(a, da) if oscillatory else (a[0], da[0])
        step = f / df
        v = np.where(np.isfinite(step), v - step, v)
    return v


def _lowest(v: FloatArray, keep: FloatArray) -> FloatArray:
    return np.min(np.where(keep, v, np.inf), axis=-1)


def critical_speeds_batch(matrices: WhippleMatrices, g: Any) -> tuple[FloatArray, FloatArray]:
    """Weave and capsize speeds (m/s) of many bicycles at once.

    The vectorised form of :func:`bike_rig.core.whipple.critical_speeds` (``v_max`` = ∞): the
    positive roots of ``a0(v)`` and of the Hurwitz determinant in closed form (quadratics in
    ``v²``), polished by Newton; the weave speed is the lowest oscillatory crossing that
    stabilises (``d Re s/dv < 0``), the capsize speed the lowest real crossing that
    destabilises.

    Args:
        matrices: Canonical matrices, batch shape (N,).
        g: Gravity, m/s², scalar or shape (N,).

    Returns:
        ``(weave, capsize)``, each shape (N,), NaN where the bicycle has no such speed.
    """
    coef = np.asarray(characteristic_polynomial(matrices, g).coefficients, dtype=float)
    if coef.ndim != 3:
        raise MonteCarloError(f"critical_speeds_batch needs matrices of shape (N, 2, 2), got {matrices.M.shape}")
    with np.errstate(all="ignore"):
        c = coef / coef[:, 4:5, 0:1]  # a4 = 1
        q2, q1, q0 = hurwitz_quadratic(np.moveaxis(c, 0, -1))  # c[k][j] of every bicycle at once
        u_real, u_osc = _quadratic_roots(c[:, 0, 4], c[:, 0, 2], c[:, 0, 0]), _quadratic_roots(q2, q1, q0)
        v_real = _polish(c, np.where(u_real > 0.0, np.sqrt(u_real), np.nan), oscillatory=False)
        v_osc = _polish(c, np.where(u_osc > 0.0, np.sqrt(u_osc), np.nan), oscillatory=True)
        # Capsize: a real root through s = 0 with rate -a0'(v)/a1(v) > 0.
        a, da = _a(c, v_real)
        rate = -da[0] / a[1]
        capsize = _lowest(v_real, (v_real > 0.0) & (a[1] != 0.0) & (da[0] != 0.0) & (rate > 0.0))
        # Weave: a pair through ±iω, ω² = a1/a3 > 0, with Re(-(∂p/∂v)/(∂p/∂s)) < 0.
        a, da = _a(c, v_osc)
        w2 = a[1] / a[3]
        rate_w = pair_crossing_rate(a, da, np.sqrt(np.where(w2 > 0.0, w2, np.nan)))
        weave = _lowest(v_osc, (v_osc > 0.0) & (a[3] != 0.0) & (w2 > 0.0) & np.isfinite(rate_w) & (rate_w < 0.0))
    return np.where(np.isfinite(weave), weave, np.nan), np.where(np.isfinite(capsize), capsize, np.nan)


def _speed_draws(name: str, draws: FloatArray, linear: SpeedWithSigma | None) -> SpeedDraws:
    ok = draws[np.isfinite(draws)]
    if ok.size >= 2:
        mean, std = float(ok.mean()), float(ok.std(ddof=1))
        lo, hi = np.percentile(ok, [15.865525393145708, 84.13447460685429])
        robust = 0.5 * float(hi - lo)
    else:
        mean = std = robust = math.nan
    return SpeedDraws(
        name,
        draws,
        mean,
        std,
        robust,
        int(draws.size - ok.size),
        None if linear is None else linear.speed,
        None if linear is None else linear.sigma,
    )


def _run(
    bicycle: str, kind: str, draws: dict[str, Any], nominal: ParameterSet, samples: int, seed: int, rider: Rider | None
) -> SpeedMonteCarlo:
    if rider is not None:
        draws = combine_rear_frame_values(draws, rider_draws(rider, draws, nominal.values(), samples, seed))
        nominal = add_rider(nominal, rider)
        bicycle = nominal.bicycle
    params = {n: np.broadcast_to(np.asarray(draws[n], dtype=float), (samples,)) for n in PARAMETER_NAMES}
    weave, capsize = critical_speeds_batch(canonical_matrices(params), params["g"])
    lin = critical_speeds_with_sigma(nominal)
    return SpeedMonteCarlo(
        bicycle,
        kind,
        samples,
        seed,
        _speed_draws("weave speed", weave, lin.weave),
        _speed_draws("capsize speed", capsize, lin.capsize),
    )


def _check_samples(samples: int) -> None:
    if samples < 2:
        raise MonteCarloError(f"a Monte Carlo needs at least 2 draws, got {samples}")


def speed_monte_carlo(
    m: Measurements,
    samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
    method: ComMethod = ComMethod.CENTROID,
    rider: Rider | None = None,
) -> SpeedMonteCarlo:
    """Weave and capsize speeds over normal draws of the raw readings.

    Args:
        m: The bicycle's readings; every reading with σ > 0 is drawn independently.
        samples: Number of draws.
        seed: Seed of the random generator (reproducible).
        method: Mass-centre method (the paper's centroid by default).
        rider: A rigid rider added to every draw (and to the linear reference), or None.

    Returns:
        The draws of both speeds, their mean, σ and missing counts, and the linear σ of
        ``compute_parameters(m, method)`` (with the rider) for comparison.

    Raises:
        MonteCarloError: ``samples`` < 2.
        MeasurementError, GeometryError: as :func:`compute_parameters`.
    """
    _check_samples(samples)
    nominal = compute_parameters(m, method)
    draws = monte_carlo_parameters(m, samples, seed, method)
    return _run(nominal.bicycle, "raw readings", dict(draws), nominal, samples, seed, rider)


def _normal_draws(mean: FloatArray, covariance: FloatArray, samples: int, seed: int) -> FloatArray:
    """Multivariate normal draws, shape (samples, n); a singular (PSD) covariance is allowed."""
    w, vecs = np.linalg.eigh(0.5 * (covariance + covariance.T))
    factor = vecs * np.sqrt(np.clip(w, 0.0, None))
    z = np.random.default_rng(seed).standard_normal((samples, mean.size))
    return np.asarray(mean + z @ factor.T, dtype=float)


def speed_monte_carlo_from_parameters(
    ps: ParameterSet, samples: int = DEFAULT_SAMPLES, seed: int = 0, rider: Rider | None = None
) -> SpeedMonteCarlo:
    """Weave and capsize speeds over multivariate normal draws of the 26 parameters.

    For a parameter file (no raw readings). Parameters with σ = 0 stay at their value; the
    covariance may be singular.

    Args:
        ps: The parameter set (values and covariance).
        samples: Number of draws.
        seed: Seed of the random generator (reproducible).
        rider: A rigid rider added to every draw (and to the linear reference), or None.

    Returns:
        As :func:`speed_monte_carlo`, with ``input_kind`` ``"parameters"``.

    Raises:
        MonteCarloError: ``samples`` < 2.
    """
    _check_samples(samples)
    pv = ps.parameters
    x = _normal_draws(np.asarray(pv.values, dtype=float), np.asarray(pv.covariance, dtype=float), samples, seed)
    draws = {n: x[:, pv.index(n)] for n in PARAMETER_NAMES}
    return _run(ps.bicycle, "parameters", draws, ps, samples, seed, rider)
