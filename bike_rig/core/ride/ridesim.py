"""Simulated ride segments as a real ride gives them, for calibrating the segment fit's σ.

:mod:`bike_rig.core.sim.ride` runs the linear closed loop with white sensor noise only; a real
balance-assist ride adds what the segment fit must survive: the rider's small steering inputs
(a steer torque following an Ornstein–Uhlenbeck process: σ ``rider_torque`` [N m], correlation
time ``rider_tau`` [s]), an assist motor whose torque saturates at ``saturation`` [N m], and a
lateral push (a roll-torque pulse) instead of a handlebar kick. The open loop ``ẋ = A x + B u``
(:func:`bike_rig.core.whipple.state_space`, ``x = [φ, δ, φ̇, δ̇]``, ``u = [T_φ, T_δ]``) is
discretised exactly for inputs held over a sample; the assist torque ``−K x`` is computed from
each sample's state, clipped, and held to the next. The roll-rate gyro adds white noise
``noise`` [rad/s]. A segment starts ``settle`` [s] after the push ends and lasts ``cycles`` of
the closed loop's weave. Units: SI, times s, rates rad/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..whipple import WhippleMatrices, state_space
from ..whipple.sampled import sampled_closed_loop_eigenvalues, zero_order_hold

__all__ = ["RideConditions", "SimulatedSegment", "simulate_log", "simulate_segment"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class RideConditions:
    """How a segment is disturbed (module docstring).

    Attributes:
        rate_hz: Sample rate [Hz].
        noise: σ of the roll-rate gyro [rad/s].
        rider_torque: σ of the rider's steer torque [N m] (0: none).
        rider_tau: Its correlation time [s].
        saturation: The assist motor's largest torque [N m] (inf: none).
        push_torque: The push's roll torque [N m].
        push_s: The push's length [s].
        settle: From the push's end to the segment's start [s].
    """

    rate_hz: float = 100.0
    noise: float = 0.01
    rider_torque: float = 0.3
    rider_tau: float = 0.3
    saturation: float = 5.0
    push_torque: float = 90.0
    push_s: float = 0.15
    settle: float = 0.3


@dataclass(frozen=True)
class SimulatedSegment:
    """One simulated segment.

    Attributes:
        times: Sample times [s] from the push's start.
        roll_rate: Measured φ̇ [rad/s].
        weave: The closed loop's weave eigenvalue [1/s], unsaturated, with the assist's torque
            held over a sample (``log(eig(A_d − B_d K)) / Δt``).
        saturated: Share of the segment's samples at which the motor saturates [-].
    """

    times: FloatArray
    roll_rate: FloatArray
    weave: complex
    saturated: float


def simulate_segment(
    matrices: WhippleMatrices,
    g: float,
    speed: float,
    gains: ArrayLike | None,
    cycles: float,
    conditions: RideConditions,
    rng: np.random.Generator,
) -> SimulatedSegment:
    """A push and the free decay after it, ``cycles`` of the weave long (module docstring).

    Args:
        matrices: The canonical matrices (with the rider) [SI].
        g: Gravity [m/s²].
        speed: Forward speed [m/s].
        gains: Assist gains ``[kφ, kδ, kφ̇, kδ̇]`` at the speed (None: no assist).
        cycles: The segment's length in weave cycles.
        conditions: Noise, rider, saturation and push.
        rng: The random generator (noise and the push's sign).
    """
    ad, bd, k, weave = _discrete(matrices, g, speed, gains, conditions.rate_hz)
    start = conditions.push_s + conditions.settle
    n = int(math.ceil((start + cycles * 2.0 * math.pi / weave.imag) * conditions.rate_hz))
    rider = rng.normal(0.0, conditions.rider_torque)
    push = conditions.push_torque * rng.choice((-1.0, 1.0))
    t, rates, clipped = _run(ad, bd, k, n, [(0.0, push)], conditions, rng, rider)
    inside = t >= start
    measured = rates[inside] + rng.normal(0.0, conditions.noise, int(inside.sum()))
    return SimulatedSegment(t[inside], measured, weave, float(np.mean(clipped[inside])))


def simulate_log(
    matrices: WhippleMatrices,
    g: float,
    speed: float,
    gains: ArrayLike | None,
    duration: float,
    pushes: tuple[float, ...],
    conditions: RideConditions,
    rng: np.random.Generator,
) -> tuple[FloatArray, FloatArray, complex]:
    """A raw ride log: ``duration`` [s] of riding with the rider steering, pushed at ``pushes`` [s].

    Returns:
        Times [s], the measured roll rate [rad/s] and the closed loop's weave eigenvalue [1/s].
    """
    ad, bd, k, weave = _discrete(matrices, g, speed, gains, conditions.rate_hz)
    rider = rng.normal(0.0, conditions.rider_torque)
    signs = rng.choice((-1.0, 1.0), len(pushes))
    n = int(round(duration * conditions.rate_hz))
    t, rates, _ = _run(
        ad,
        bd,
        k,
        n,
        [(p, s * conditions.push_torque) for p, s in zip(pushes, signs, strict=True)],
        conditions,
        rng,
        rider,
    )
    return t, rates + rng.normal(0.0, conditions.noise, n), weave


def _discrete(
    matrices: WhippleMatrices, g: float, speed: float, gains: ArrayLike | None, rate_hz: float
) -> tuple[FloatArray, FloatArray, FloatArray, complex]:
    """The sampled open loop (A_d, B_d), the gains and the sampled closed loop's weave eigenvalue."""
    a, b = state_space(matrices, speed, g)
    k = np.zeros(4) if gains is None else np.asarray(gains, dtype=float)
    dt = 1.0 / rate_hz
    ad, bd = zero_order_hold(a, b, dt)
    lam = sampled_closed_loop_eigenvalues(matrices, speed, g, k, dt)
    return ad, bd, k, complex(lam[np.argmax(lam.imag)])


def _run(
    ad: FloatArray,
    bd: FloatArray,
    k: FloatArray,
    n: int,
    pushes: list[tuple[float, float]],
    conditions: RideConditions,
    rng: np.random.Generator,
    rider: float,
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """Times [s], true roll rates [rad/s] and where the motor saturates over n samples; ``rider``: its first torque."""
    dt = 1.0 / conditions.rate_hz
    decay = math.exp(-dt / conditions.rider_tau) if conditions.rider_tau > 0 else 0.0
    x = np.zeros(4)
    rates = np.empty(n)
    clipped = np.zeros(n, dtype=bool)
    for i in range(n):
        rates[i] = x[2]
        demand = -float(k @ x)
        assist = min(conditions.saturation, max(-conditions.saturation, demand))
        clipped[i] = assist != demand
        push = sum(p for t0, p in pushes if t0 <= i * dt < t0 + conditions.push_s)
        x = ad @ x + bd @ np.array([push, assist + rider])
        rider = decay * rider + math.sqrt(1.0 - decay**2) * rng.normal(0.0, conditions.rider_torque)
    return np.arange(n, dtype=np.float64) * dt, rates, clipped
