"""How well the segments' σ describe their scatter on simulated rides: pooled χ²/dof at one speed.

Groups of segments are simulated at each speed (:mod:`.ridesim`: a push, the rider's steering,
the assist motor's saturation, gyro noise) and fitted (:func:`.eigen.fit_segment`); one group at
each speed makes a record, as a ride gives them, whose drive is shared per speed
(:func:`.eigen.pool_drive`); the clean ones of each group set against their weighted
mean: ``χ² = Σ (x_i − x̄)² / σ_i²`` with n − 1 degrees of freedom, pooled over the groups and
speeds (≈ 1 when the σ are right), for Re λ and Im λ apart; beside it the RMS of the normalised
errors against the simulated weave eigenvalue. Units: speeds m/s, eigenvalues 1/s.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..whipple import WhippleMatrices
from .eigen import MeasuredEigenvalue, fit_segment, pool_drive
from .ridesim import RideConditions, SimulatedSegment, simulate_segment

__all__ = ["Calibration", "measure_calibration"]


@dataclass(frozen=True)
class Calibration:
    """The pooled scatter of simulated segments.

    Attributes:
        segments: Segments simulated.
        clean: Clean ones (in the χ²).
        dof: Pooled degrees of freedom (Σ (n_clean − 1) over the groups).
        chi2_real: Pooled χ²/dof of Re λ about each group's weighted mean [-].
        chi2_imag: Of Im λ [-].
        z_real: RMS of (Re λ − the simulated weave's) / σ over the clean segments [-].
        z_imag: Of Im λ [-].
    """

    segments: int
    clean: int
    dof: int
    chi2_real: float
    chi2_imag: float
    z_real: float
    z_imag: float


def _chi2(x: NDArray[np.float64], sigma: NDArray[np.float64]) -> float:
    w = 1.0 / sigma**2
    mean = float(np.sum(w * x) / np.sum(w))
    return float(np.sum(w * (x - mean) ** 2))


def measure_calibration(
    matrices: WhippleMatrices,
    g: float,
    gains_at: Callable[[float], NDArray[np.float64] | None],
    speeds: Sequence[float],
    conditions: RideConditions,
    groups: int,
    per_group: int = 3,
    cycles: tuple[float, float] = (1.2, 2.5),
    seed: int = 0,
    model: str = "auto",
) -> Calibration:
    """Simulate ``groups`` records of ``per_group`` segments at each speed and pool their χ² (module docstring).

    Args:
        matrices: The canonical matrices (with the rider) [SI].
        g: Gravity [m/s²].
        gains_at: The assist's gains at a speed [m/s] (None: no assist).
        speeds: m/s.
        conditions: The rider, motor, gyro and push.
        groups: Records (one group at each speed).
        per_group: Segments per group (at one speed).
        cycles: The segments' lengths are drawn uniformly from this range [weave cycles].
        seed: Seed of the random generator (reproducible).
        model: The segment model (:data:`.eigen.MODELS`).
    """
    rng = np.random.default_rng(seed)
    simulated: list[list[tuple[list[SimulatedSegment], list[MeasuredEigenvalue]]]] = []
    for v in speeds:
        gains = gains_at(v)
        at_speed = []
        for _ in range(groups):
            sims = [
                simulate_segment(matrices, g, v, gains, float(rng.uniform(*cycles)), conditions, rng)
                for _ in range(per_group)
            ]
            at_speed.append((sims, [fit_segment(s.times, s.roll_rate, speed=v, model=model) for s in sims]))
        simulated.append(at_speed)
    chi2 = [0.0, 0.0]
    dof = n = n_clean = 0
    z: list[tuple[float, float]] = []
    for record in zip(*simulated, strict=True):  # one group at each speed
        pooled = iter(pool_drive([f for _, fits in record for f in fits]))
        for sims, raw in record:
            fits = [next(pooled) for _ in raw]
            n += len(fits)
            clean = [(f, s) for f, s in zip(fits, sims, strict=True) if f.clean]
            n_clean += len(clean)
            z += [((f.real - s.weave.real) / f.real_sigma, (f.imag - s.weave.imag) / f.imag_sigma) for f, s in clean]
            if len(clean) < 2:
                continue
            chi2[0] += _chi2(np.array([f.real for f, _ in clean]), np.array([f.real_sigma for f, _ in clean]))
            chi2[1] += _chi2(np.array([f.imag for f, _ in clean]), np.array([f.imag_sigma for f, _ in clean]))
            dof += len(clean) - 1
    zz = np.array(z) if z else np.full((1, 2), math.nan)
    rms = np.sqrt(np.mean(zz**2, axis=0))
    nan = math.nan
    return Calibration(
        n, n_clean, dof, chi2[0] / dof if dof else nan, chi2[1] / dof if dof else nan, float(rms[0]), float(rms[1])
    )
