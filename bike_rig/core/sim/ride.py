"""A simulated ride: the linear Whipple model (with rider and feedback) perturbed at one speed.

The state ``x = [φ, δ, φ̇, δ̇]`` follows ``ẋ = A x + B u`` (:func:`bike_rig.core.whipple.state_space`,
or the closed loop ``A − B K`` of :func:`bike_rig.core.whipple.closed_loop.closed_loop_state_space`)
with ``u = [T_φ, T_δ]`` the perturbations: rectangular torque pulses ("kicks", a push at the
seat post and a jerk of the handlebar). The model is discretised exactly for inputs held
over a sample (zero-order hold, :func:`scipy.signal.cont2discrete`) and run with
:func:`scipy.signal.dlsim`; between kicks the bicycle moves freely. A feedback with a rate is
digital instead: it reads the state at its own instants and holds its torque to the next
(the open loop stepped exactly between instants). The sensors add white
Gaussian noise: roll rate φ̇ [rad/s], steer angle δ [rad], steer rate δ̇ [rad/s], speed [m/s]
and the perturbing steer torque T_δ [N m], at the sample rate. Reproducible from one seed.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..whipple import WhippleMatrices, state_space
from ..whipple.closed_loop import closed_loop_state_space
from ..whipple.sampled import sampled_closed_loop_eigenvalues, zero_order_hold
from .errors import SimulationError

__all__ = ["Kick", "RideSimulation", "SimulatedRide", "regular_kicks", "simulate_ride", "write_ride_csv"]

FloatArray = NDArray[np.float64]

#: The columns of a simulated ride's CSV file, in order.
RIDE_COLUMNS = ("time", "roll_rate", "steer_angle", "steer_rate", "speed", "steer_torque")


@dataclass(frozen=True)
class Kick:
    """One perturbation: torque pulses held for ``duration``.

    Attributes:
        time: Start [s].
        duration: Length of the pulse [s].
        roll_torque: T_φ during the pulse [N m].
        steer_torque: T_δ during the pulse [N m].
    """

    time: float
    duration: float = 0.1
    roll_torque: float = 0.0
    steer_torque: float = 5.0


@dataclass(frozen=True)
class RideSimulation:
    """What to simulate.

    Attributes:
        speed: Forward speed [m/s].
        duration: Length of the record [s].
        rate_hz: Sample rate [Hz].
        kicks: The perturbations.
        noise_roll_rate: σ of the roll-rate sensor [rad/s].
        noise_steer_angle: σ of the steer-angle sensor [rad].
        noise_steer_rate: σ of the steer-rate sensor [rad/s].
        noise_speed: σ of the speed sensor [m/s].
        noise_torque: σ of the steer-torque sensor [N m].
        seed: Seed of the noise.
    """

    speed: float
    duration: float
    rate_hz: float = 100.0
    kicks: tuple[Kick, ...] = field(default=(Kick(0.5),))
    noise_roll_rate: float = 0.01
    noise_steer_angle: float = 0.001
    noise_steer_rate: float = 0.01
    noise_speed: float = 0.05
    noise_torque: float = 0.05
    seed: int = 0


@dataclass(frozen=True)
class SimulatedRide:
    """A simulated ride's sensor signals and the truth.

    Attributes:
        times: Sample times [s].
        roll_rate: Measured φ̇ [rad/s].
        steer_angle: Measured δ [rad].
        steer_rate: Measured δ̇ [rad/s].
        speed: Measured speed [m/s].
        steer_torque: Measured perturbing T_δ [N m].
        states: The true states [φ, δ, φ̇, δ̇], shape (n, 4).
        eigenvalues: The eigenvalues of the simulated A [1/s].
        kicks: The perturbations.
    """

    times: FloatArray
    roll_rate: FloatArray
    steer_angle: FloatArray
    steer_rate: FloatArray
    speed: FloatArray
    steer_torque: FloatArray
    states: FloatArray
    eigenvalues: NDArray[np.complex128]
    kicks: tuple[Kick, ...]


def regular_kicks(
    duration: float, interval: float, first: float = 1.0, steer_torque: float = 5.0, pulse: float = 0.1
) -> tuple[Kick, ...]:
    """Kicks every ``interval`` seconds from ``first`` while a whole interval fits, alternating in sign."""
    times = np.arange(first, duration - 0.5 * interval, interval)
    return tuple(Kick(float(t), pulse, 0.0, steer_torque * (-1.0) ** i) for i, t in enumerate(times))


def simulate_ride(
    matrices: WhippleMatrices,
    g: float,
    sim: RideSimulation,
    gains: ArrayLike | None = None,
    controller_hz: float | None = None,
) -> SimulatedRide:
    """Simulate a ride (module docstring).

    Args:
        matrices: The canonical matrices of the bicycle (with its rider) [SI].
        g: Gravity [m/s²].
        sim: Speed, duration, rate, kicks, sensor noise and seed.
        gains: Steer-torque feedback ``[kφ, kδ, kφ̇, kδ̇]`` at the speed (None: the open loop).
        controller_hz: The feedback's rate [Hz]: it samples the state at ``j / controller_hz``
            and holds its torque to the next (:func:`_sampled_states`); None: continuous.

    Raises:
        SimulationError: A non-positive duration, rate or controller rate, or a negative speed.
    """
    from scipy.signal import cont2discrete, dlsim

    if not (sim.duration > 0 and sim.rate_hz > 0 and sim.speed >= 0):
        raise SimulationError(
            f"a ride needs duration > 0 s, rate > 0 Hz and speed >= 0 m/s, "
            f"got {sim.duration} s, {sim.rate_hz} Hz, {sim.speed} m/s"
        )
    if controller_hz is not None and not (math.isfinite(controller_hz) and controller_hz > 0):
        raise SimulationError(f"the feedback's rate must be a finite number > 0 Hz, got {controller_hz}")
    sampled = gains is not None and controller_hz is not None
    if gains is None or sampled:
        a, b = state_space(matrices, sim.speed, g)
    else:
        a, b = closed_loop_state_space(matrices, sim.speed, g, np.asarray(gains, dtype=float))
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    dt = 1.0 / sim.rate_hz
    n = int(round(sim.duration * sim.rate_hz))
    t = np.arange(n, dtype=np.float64) * dt
    u = _inputs(t, sim.kicks, dt)
    if sampled:
        assert gains is not None and controller_hz is not None
        k = np.asarray(gains, dtype=float)
        x = _sampled_states(a, b, k, u, dt, 1.0 / controller_hz)
        eigenvalues = sampled_closed_loop_eigenvalues(matrices, sim.speed, g, k, 1.0 / controller_hz)
    else:
        ad, bd, _, _, _ = cont2discrete((a, b, np.eye(4), np.zeros((4, 2))), dt, method="zoh")
        _, _, x = dlsim((ad, bd, np.eye(4), np.zeros((4, 2)), dt), u)  # (one output per input row)
        eigenvalues = np.asarray(np.linalg.eigvals(a), dtype=np.complex128)
    x = np.asarray(x, dtype=float)
    rng = np.random.default_rng(sim.seed)

    def noisy(clean: FloatArray, sigma: float) -> FloatArray:
        return clean + rng.normal(0.0, sigma, clean.shape) if sigma > 0 else clean.copy()

    return SimulatedRide(
        times=t,
        roll_rate=noisy(x[:, 2], sim.noise_roll_rate),
        steer_angle=noisy(x[:, 1], sim.noise_steer_angle),
        steer_rate=noisy(x[:, 3], sim.noise_steer_rate),
        speed=noisy(np.full(n, float(sim.speed)), sim.noise_speed),
        steer_torque=noisy(u[:, 1], sim.noise_torque),
        states=x,
        eigenvalues=np.asarray(eigenvalues, dtype=np.complex128),
        kicks=tuple(sim.kicks),
    )


def _sampled_states(a: FloatArray, b: FloatArray, k: FloatArray, u: FloatArray, dt: float, period: float) -> FloatArray:
    """The states at the samples ``i dt`` [SI] of the open loop ``(A, B)`` under the kicks ``u`` and a sampled feedback.

    The feedback reads the state at ``j T`` (``T = period``) and holds ``T_δ = −K x(jT)`` to the
    next; the kicks ``u[i]`` are held over each sample. The record is stepped exactly (zero-order
    hold, :func:`~bike_rig.core.whipple.sampled.zero_order_hold`) from each instant of either
    kind to the next; instants are merged on a 1 ns grid.
    """
    n = u.shape[0]
    ns = 1e9
    samples = np.round(np.arange(n + 1) * dt * ns).astype(np.int64)
    reads = np.round(np.arange(int(np.floor(samples[-1] / (period * ns))) + 1) * period * ns).astype(np.int64)
    instants = np.union1d(samples, reads[reads <= samples[-1]])
    maps: dict[int, tuple[FloatArray, FloatArray]] = {}
    x = np.zeros(4)
    torque = np.zeros(2)
    out = np.empty((n, 4))
    sample = 0
    read = set(reads.tolist())
    for now, later in zip(instants[:-1], instants[1:], strict=True):
        if sample < n and now == samples[sample]:
            out[sample] = x
            kick = u[sample]
            sample += 1
        if int(now) in read:
            torque = np.array([0.0, -float(k @ x)])
        step = int(later - now)
        if step not in maps:
            maps[step] = zero_order_hold(a, b, step / ns)
        phi, gamma = maps[step]
        x = phi @ x + gamma @ (kick + torque)
    return out


def _inputs(t: FloatArray, kicks: Sequence[Kick], dt: float) -> FloatArray:
    """The torques [T_φ, T_δ] held over each sample [N m] (a pulse covers the samples it overlaps most)."""
    u = np.zeros((t.size, 2))
    for k in kicks:
        on = (t + 0.5 * dt >= k.time) & (t + 0.5 * dt < k.time + k.duration)
        u[on, 0] += k.roll_torque
        u[on, 1] += k.steer_torque
    return u


def write_ride_csv(ride: SimulatedRide, path: str | Path) -> None:
    """Write the sensor signals as CSV (columns :data:`RIDE_COLUMNS`; SI units, time in s)."""
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(RIDE_COLUMNS)
        cols = (ride.times, ride.roll_rate, ride.steer_angle, ride.steer_rate, ride.speed, ride.steer_torque)
        for row in zip(*cols, strict=True):
            w.writerow([f"{row[0]:.4f}", *(f"{x:.6g}" for x in row[1:])])
