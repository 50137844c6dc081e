"""A sampled steer-torque feedback (zero-order hold): the eigenvalues against independent computations.

:func:`sampled_closed_loop_eigenvalues` (``expm`` of the augmented matrix) is checked against
``scipy.signal.cont2discrete``, against the one-period map built column by column from an ODE
integration of the continuous model with the torque held, against the continuous loop as
``T → 0``, and against the raw-log simulator's own sampled loop (its push responses' linear
recurrence, fitted).
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import cache

import numpy as np
import pytest
from numpy.typing import NDArray
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.signal import cont2discrete

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.errors import ModelError
from bike_rig.core.feedback import load_feedback
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.sim.errors import SimulationError
from bike_rig.core.sim.ride_log import RideLog, simulate_raw_log
from bike_rig.core.uncertainty.matrix_sigma import MatrixSet, canonical_with_sigma
from bike_rig.core.whipple import state_space
from bike_rig.core.whipple.closed_loop import closed_loop_state_space
from bike_rig.core.whipple.sampled import NYQUIST_SHARE, aliased, sampled_closed_loop_eigenvalues, zero_order_hold

SPEEDS = np.array([1.0, 2.5, 4.0, 5.5, 7.0])
#: A controller with every gain non-zero (N m/rad, N m/rad, N m s/rad, N m s/rad).
GAINS = np.array([-3.0, 1.5, -30.0, 0.8])


@cache
def _bicycle(name: str) -> MatrixSet:
    """A shipped bicycle with the paper's rider."""
    return canonical_with_sigma(
        add_rider(_parameters(str(config_file(f"bicycles/{name}.yaml")), "centroid"), PAPER_RIDER)
    )


def _same(ours: NDArray[np.complex128], ref: NDArray[np.complex128]) -> float:
    """Largest distance from each of ``ref`` to the nearest of ``ours`` [1/s]."""
    return float(np.abs(ours[..., None, :] - ref[..., :, None]).min(axis=-1).max())


@pytest.mark.parametrize("name", ["browser", "crescendo", "benchmark"])
@pytest.mark.parametrize("rate", [20.0, 100.0, 1000.0])
def test_eigenvalues_match_cont2discrete(name: str, rate: float) -> None:
    """The batched ``expm`` equals ``cont2discrete``'s zero-order hold, speed by speed."""
    ms = (
        _bicycle(name)
        if name != "benchmark"
        else canonical_with_sigma(_parameters(str(config_file("bicycles/benchmark.yaml")), "centroid"))
    )
    gains = np.broadcast_to(GAINS, SPEEDS.shape + (4,))
    ours = sampled_closed_loop_eigenvalues(ms.matrices, SPEEDS, ms.g, gains, 1.0 / rate)
    assert ours.shape == (SPEEDS.size, 4)
    for i, v in enumerate(SPEEDS):
        a, b = (np.asarray(m, dtype=float) for m in state_space(ms.matrices, v, ms.g))
        ad, bd, *_ = cont2discrete((a, b[:, 1:], np.eye(4), np.zeros((4, 1))), 1.0 / rate, method="zoh")
        ref = np.log(np.linalg.eigvals(ad - bd @ GAINS[None, :]).astype(complex)) * rate
        assert _same(ours[i], ref) < 1e-9 * max(1.0, float(np.abs(ref).max()))


@pytest.mark.parametrize("period", [1e-3, 0.01, 0.05, 0.5])
def test_zero_order_hold_matches_scipy_expm_matrix_by_matrix(period: float) -> None:
    """``(Φ, Γ)`` of a batch of speeds (both inputs) equals ``scipy.linalg.expm`` of each augmented matrix.

    To 1e-12 of the largest entry: at T = 0.5 s (nine squarings) ``e^{A T}``'s condition number
    is ~1e3, so two correct methods differ by ~1e-13 there.
    """
    ms = _bicycle("crescendo")
    speeds = np.linspace(0.0, 10.0, 41)
    a, b = (np.asarray(m, dtype=float) for m in state_space(ms.matrices, speeds, ms.g))
    phi, gamma = zero_order_hold(a, b, period)
    assert phi.shape == (speeds.size, 4, 4) and gamma.shape == (speeds.size, 4, 2)
    for i in range(speeds.size):
        aug = np.zeros((6, 6))
        aug[:4, :4], aug[:4, 4:] = a[i], b
        ref = expm(aug * period)
        assert np.abs(phi[i] - ref[:4, :4]).max() < 1e-12 * np.abs(ref[:4, :4]).max()
        assert np.abs(gamma[i] - ref[:4, 4:]).max() < 1e-12 * np.abs(ref[:4, 4:]).max()


def test_zero_order_hold_refuses_what_it_cannot_hold() -> None:
    """A non-finite ``A`` or period, or an ``e^{A T}`` beyond floating point, is a ModelError."""
    a, b = (np.asarray(m, dtype=float) for m in state_space(_bicycle("browser").matrices, 4.0, 9.81))
    with pytest.raises(ModelError, match="not finite"):
        zero_order_hold(np.where(np.eye(4) > 0, math.nan, a), b, 0.01)
    with pytest.raises(ModelError, match="finite period > 0 s"):
        zero_order_hold(a, b, math.inf)
    with pytest.raises(ModelError, match="beyond floating point"):
        zero_order_hold(a, b, 1e6)


def test_eigenvalues_match_an_integration_of_the_held_loop() -> None:
    """The map over one period, built from an ODE solution of ``ẋ = A x − b K x(0)`` per unit state."""
    ms = _bicycle("browser")
    period = 0.02
    for v in (2.0, 5.0):
        a, b = (np.asarray(m, dtype=float) for m in state_space(ms.matrices, v, ms.g))
        torque_per_state = -b[:, 1][:, None] * GAINS[None, :]  # ẋ = A x + b T, T = −K x0 held
        columns = []
        for e in np.eye(4):
            sol = solve_ivp(
                lambda _t, x, x0=e, a=a, h=torque_per_state: a @ x + h @ x0, (0.0, period), e, rtol=1e-12, atol=1e-14
            )
            columns.append(sol.y[:, -1])
        ref = np.log(np.linalg.eigvals(np.array(columns).T).astype(complex)) / period
        ours = sampled_closed_loop_eigenvalues(ms.matrices, v, ms.g, GAINS, period)
        assert _same(ours, ref) < 1e-7 * float(np.abs(ref).max())


def test_short_periods_give_the_continuous_loop() -> None:
    """``λ(T) → eig(A − B K)`` as ``T → 0``, the gap shrinking in proportion to ``T`` (a half-period delay)."""
    ms = _bicycle("browser")
    gains = np.broadcast_to(GAINS, SPEEDS.shape + (4,))
    a, _ = closed_loop_state_space(ms.matrices, SPEEDS, ms.g, gains)
    cont = np.linalg.eigvals(np.asarray(a, dtype=float))
    gaps = [_same(sampled_closed_loop_eigenvalues(ms.matrices, SPEEDS, ms.g, gains, t), cont) for t in (1e-2, 1e-3)]
    assert gaps[0] > 1e-3  # a 100 Hz hold is visible
    assert 7.0 < gaps[0] / gaps[1] < 13.0  # first order in T
    assert _same(sampled_closed_loop_eigenvalues(ms.matrices, SPEEDS, ms.g, gains, 1e-6), cont) < 1e-4


def test_a_slow_controller_is_flagged_and_bad_periods_refused() -> None:
    """A mode beyond half of π/T is aliased; a period that is not finite and > 0 is a ModelError."""
    ms = _bicycle("browser")
    fast = sampled_closed_loop_eigenvalues(ms.matrices, 4.0, ms.g, GAINS, 0.01)
    assert not aliased(fast, 0.01).any()
    weave = max(abs(fast.imag))
    slow = 1.2 * math.pi * NYQUIST_SHARE / weave * 2.0  # π/T below twice the weave's frequency
    lam = sampled_closed_loop_eigenvalues(ms.matrices, 4.0, ms.g, GAINS, slow)
    assert aliased(lam, slow).any()
    assert aliased(np.array([-np.inf + 0j]), 0.01).all()
    for bad in (0.0, -0.01, math.nan, math.inf):
        with pytest.raises(ModelError, match="finite period > 0 s"):
            sampled_closed_loop_eigenvalues(ms.matrices, 4.0, ms.g, GAINS, bad)
    with pytest.raises(ModelError, match="beyond floating point"):
        sampled_closed_loop_eigenvalues(ms.matrices, 4.0, ms.g, GAINS, 1e6)


def _recurrence_eigenvalues(y: NDArray[np.float64], period: float) -> NDArray[np.complex128]:
    """``ln z / T`` of the 4th-order linear recurrence fitted (least squares) to ``y`` sampled every ``T``."""
    rows = np.column_stack([y[3 - k : y.size - 1 - k] for k in range(4)])
    coef, *_ = np.linalg.lstsq(rows, y[4:], rcond=None)
    z = np.roots(np.r_[1.0, -coef]).astype(complex)
    return np.asarray(np.log(z) / period)


@pytest.mark.parametrize("controller_hz", [None, 50.0, 400.0])
def test_the_raw_log_simulators_assist_runs_at_the_feedbacks_rate(controller_hz: float | None) -> None:
    """A push's free decay in the raw-log simulator is the sampled loop's at the controller's rate.

    The recurrence fitted to the noise-free response at the controller's ticks (or the log's samples
    for a faster controller) has the weave of ``sampled_closed_loop_eigenvalues`` at that rate.
    """
    ms = _bicycle("browser")
    fb = load_feedback(config_file("feedback/balance_assist.yaml"))
    plan = RideLog(
        20.0,
        4.0,
        starts=(-7.0,),
        pushes=(8.0,),
        rider_torque=0.0,
        saturation=1e9,
        gains=lambda v: np.asarray(fb.gains(v), dtype=float),
        controller_hz=controller_hz,
    )
    log = simulate_raw_log(ms.matrices, ms.g, plan, np.random.default_rng(2))
    (push,) = log.pushes
    rate = controller_hz or plan.rate_hz
    hold = max(1, round(plan.rate_hz / rate))
    first = int(np.searchsorted(log.times, push.time))
    ticks = [i for i in range(first, first + push.response.size) if i % hold == 0 and log.times[i] > push.start + 0.05]
    y = push.response[np.array(ticks[:400]) - first]
    step = hold / plan.rate_hz
    fitted = _recurrence_eigenvalues(y, step)
    expect = sampled_closed_loop_eigenvalues(ms.matrices, 4.0, ms.g, fb.gains(4.0), 1.0 / rate)
    weave = expect[np.argmax(expect.imag)]
    assert np.min(np.abs(fitted - weave)) < 1e-5 * abs(weave)
    if controller_hz != plan.rate_hz:
        cont = np.linalg.eigvals(np.asarray(closed_loop_state_space(ms.matrices, 4.0, ms.g, fb.gains(4.0))[0]))
        assert np.min(np.abs(fitted - cont[np.argmax(cont.imag)])) > 1e-3  # the rate shows


def test_the_raw_log_simulator_refuses_a_rate_it_cannot_step() -> None:
    ms = _bicycle("browser")
    for hz, match in (
        (math.nan, "finite number > 0 Hz"),
        (-5.0, "finite number > 0 Hz"),
        (100.0 * math.pi, "simple ratio"),
    ):
        with pytest.raises(SimulationError, match=match):
            simulate_raw_log(ms.matrices, ms.g, replace(RideLog(5.0, 4.0), controller_hz=hz), np.random.default_rng(0))


@pytest.mark.parametrize(("sample_hz", "controller_hz"), [(100.0, 100.0), (200.0, 50.0), (100.0, 300.0)])
def test_the_kick_simulator_runs_the_sampled_loop(sample_hz: float, controller_hz: float) -> None:
    """``ride simulate``'s kicks with a rated feedback: its states recur with the sampled loop's map.

    Free of kicks and noise, the states at the controller's instants (at the samples, when the
    controller is faster: three of its periods a sample here) follow one linear map; fitted from
    the states, its eigenvalues are the sampled loop's, not the continuous loop's.
    """
    from bike_rig.core.sim.ride import Kick, RideSimulation, simulate_ride

    ms = _bicycle("browser")
    v = 4.0
    sim = RideSimulation(v, 6.0, sample_hz, (Kick(0.2, 0.1, 0.0, 5.0),), 0.0, 0.0, 0.0, 0.0, 0.0)
    ride = simulate_ride(ms.matrices, ms.g, sim, GAINS, controller_hz)
    every = max(1, round(sample_hz / controller_hz))  # samples per step of the map fitted
    free = ride.states[int(0.4 * sample_hz) :: every]
    m, *_ = np.linalg.lstsq(free[:-1], free[1:], rcond=None)
    fitted = np.log(np.linalg.eigvals(m.T).astype(complex)) * sample_hz / every
    sampled = sampled_closed_loop_eigenvalues(ms.matrices, v, ms.g, GAINS, 1.0 / controller_hz)
    a, _ = closed_loop_state_space(ms.matrices, v, ms.g, GAINS)
    continuous = np.linalg.eigvals(np.asarray(a, dtype=float))
    assert _same(fitted, sampled) < 1e-6 * np.max(np.abs(sampled))
    assert _same(fitted, continuous) > 100 * _same(fitted, sampled)
    assert np.allclose(np.sort_complex(ride.eigenvalues), np.sort_complex(sampled))
