"""A real pendulum's motion: dry (Coulomb) friction and a finite swing, integrated numerically.

``θ'' + 2 ζ ω₀ θ' + ω₀² f(θ) + μ sgn(θ') = 0`` with ``f = sin θ`` (compound) or ``θ``
(torsional), ``ω₀ = 2π/T₀`` and μ the friction torque over the inertia (rad/s²). Dry friction
gives a linear envelope and stops the swing for good, leaving a linear oscillator's period
unchanged; a finite swing lengthens the period, ``T ≈ T₀ (1 + θ₀²/16 + 11 θ₀⁴/3072 + …)``.
Integrated half-swing by half-swing (θ' keeps its sign between turning points) with DOP853
(``scipy.integrate.solve_ivp``) to a relative tolerance of 1e-11.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .errors import SimulationError

__all__ = ["PendulumMotion", "pendulum_rate", "small_swing_factor"]

FloatArray = NDArray[np.float64]

_RTOL = 1e-11
_ATOL_FRACTION = 1e-13


@dataclass(frozen=True)
class PendulumMotion:
    """One pendulum's equation of motion.

    Attributes:
        period: Small-swing undamped period T₀ = 2π/ω₀, s.
        amplitude: Initial swing θ₀ (the first turning point), rad.
        damping_ratio: Viscous damping ratio ζ, 1.
        friction: Dry friction torque over the inertia μ, rad/s².
        compound: Restoring torque ∝ sin θ (a compound pendulum) rather than ∝ θ (torsional).
    """

    period: float
    amplitude: float
    damping_ratio: float = 0.0
    friction: float = 0.0
    compound: bool = False

    def __post_init__(self) -> None:
        """Check the motion.

        Raises:
            SimulationError: A period or swing that is not positive and finite (a compound
                swing of π or more), a damping ratio outside [0, 1) or a negative friction.
        """
        if not (math.isfinite(self.period) and self.period > 0):
            raise SimulationError(f"a pendulum's period must be a positive number of seconds, got {self.period!r}")
        limit = math.pi if self.compound else math.inf
        if not (math.isfinite(self.amplitude) and 0 < self.amplitude < limit):
            raise SimulationError(f"a pendulum's swing must be in (0, {limit:g}) rad, got {self.amplitude!r}")
        if not (math.isfinite(self.damping_ratio) and 0 <= self.damping_ratio < 1):
            raise SimulationError(f"a damping ratio must be in [0, 1), got {self.damping_ratio!r}")
        if not (math.isfinite(self.friction) and self.friction >= 0):
            raise SimulationError(f"a dry friction must be a non-negative number, got {self.friction!r}")

    @property
    def omega0(self) -> float:
        """ω₀, rad/s."""
        return 2.0 * math.pi / self.period


def small_swing_factor(theta0: float) -> float:
    """T(θ₀) / T₀ of an undamped compound pendulum: 2 K(sin(θ₀/2)) / π, 1.

    Args:
        theta0: Swing amplitude, rad (|θ₀| < π).
    """
    from scipy.special import ellipk

    k = math.sin(0.5 * theta0)
    return float(2.0 * ellipk(k * k) / math.pi)


def pendulum_rate(t: FloatArray, motion: PendulumMotion, phase_time: float = 0.0) -> FloatArray:
    """The rate θ'(t) a gyro on the pendulum senses, rad/s.

    Args:
        t: Sample times, s, non-decreasing, from 0.
        motion: The pendulum.
        phase_time: The motion starts at its first turning point (θ = θ₀, θ' = 0) at
            ``−phase_time`` s, so that a trial starts at any phase, s (≥ 0).

    Returns:
        θ'(t), rad/s; 0 once the friction has stopped the swing.
    """
    from scipy.integrate import solve_ivp

    t = np.asarray(t, dtype=np.float64)
    out = np.zeros_like(t)
    if t.size == 0:
        return out
    if np.any(np.diff(t) < 0) or not (phase_time >= 0):
        raise SimulationError("pendulum_rate needs non-decreasing times and a non-negative phase time")
    w0, zeta, mu = motion.omega0, motion.damping_ratio, motion.friction
    w2 = w0 * w0
    restoring = np.sin if motion.compound else (lambda x: x)
    t_end = float(t[-1]) + phase_time
    tt = t + phase_time
    theta, t0 = motion.amplitude, 0.0
    atol = _ATOL_FRACTION * motion.amplitude * max(1.0, w0)
    while t0 <= t_end:
        sign = -1.0 if theta > 0 else 1.0  # the direction of the coming half swing
        if w2 * abs(float(restoring(theta))) <= mu:
            break  # static friction holds it: the swing has stopped

        def rhs(_: float, x: FloatArray, sign: float = sign) -> list[float]:
            return [x[1], -2.0 * zeta * w0 * x[1] - w2 * float(restoring(x[0])) - mu * sign]

        def turning(_: float, x: FloatArray) -> float:
            return float(x[1])

        turning.terminal = True  # type: ignore[attr-defined]
        # θ' returns to 0 from the side of its sign
        turning.direction = -sign  # type: ignore[attr-defined]
        horizon = t0 + 4.0 * motion.period * max(1.0, 1.0 / math.sqrt(max(1e-12, 1.0 - zeta * zeta)))
        sol = solve_ivp(
            rhs,
            (t0, horizon),
            [theta, 0.0],
            method="DOP853",
            rtol=_RTOL,
            atol=atol,
            dense_output=True,
            events=turning,
        )
        if not sol.t_events[0].size:
            raise SimulationError("the pendulum did not reach its next turning point (damping too strong?)")
        t1 = float(sol.t_events[0][0])
        inside = (tt >= t0) & (tt < t1)
        if np.any(inside):
            out[inside] = sol.sol(tt[inside])[1]
        theta = float(sol.y_events[0][0][0])
        t0 = t1
    return out
