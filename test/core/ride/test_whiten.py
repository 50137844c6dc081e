"""The riding's AR noise model and the generalised least-squares decay fit it gives."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest
from scipy.linalg import toeplitz
from scipy.signal import lfilter

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.ride import segment as seg_mod
from bike_rig.core.ride.record import RideRecord
from bike_rig.core.ride.segment import SegmentOptions, segment_record
from bike_rig.core.ride.whiten import NoiseAR, fit_noise_ar
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.sim.ride_log import RideLog, SimulatedLog, simulate_raw_log
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma

#: A weave-like AR(2): poles at radius 0.99, 1.5 Hz at 100 Hz.
RADIUS, FREQ, RATE = 0.99, 1.5, 100.0
PHI = np.array([2.0 * RADIUS * math.cos(2.0 * math.pi * FREQ / RATE), -(RADIUS**2)])


def _ar2(n: int, rng: np.random.Generator, white: float = 0.0) -> np.ndarray:
    """A stationary stretch of the AR(2) (burn-in dropped), plus white noise of σ ``white``."""
    e = rng.normal(0.0, 1.0, n + 2000)
    x = np.asarray(lfilter([1.0], np.r_[1.0, -PHI], e), dtype=float)[2000:]
    return x + rng.normal(0.0, white, n) if white else x


def _acov(model: NoiseAR, n: int) -> np.ndarray:
    """The model's autocovariance γ₀…γ_{n−1} (its Yule–Walker recursion)."""
    gamma = np.zeros(n)
    gamma[: model.order] = model.acov
    for k in range(model.order, n):  # γ_k = Σ_j φ_j γ_{k−j}
        gamma[k] = model.coef @ gamma[k - 1 :: -1][: model.order]
    return gamma


def test_an_ar_process_is_recovered_and_whitened() -> None:
    rng = np.random.default_rng(1)
    model = fit_noise_ar(_ar2(4000, rng), 12)
    assert model is not None
    roots = np.roots(np.r_[1.0, -model.coef])
    weave = roots[np.argmax(np.abs(roots))]  # the resonance (Yule–Walker may add fast poles beside it)
    assert abs(weave) == pytest.approx(RADIUS, abs=0.005)
    assert abs(np.angle(weave)) * RATE / (2.0 * math.pi) == pytest.approx(FREQ, rel=0.05)
    w = model.whiten(_ar2(3000, rng))
    assert np.var(w) == pytest.approx(1.0, rel=0.1)
    lag = [abs(float(np.corrcoef(w[:-k], w[k:])[0, 1])) for k in (1, 2, 5, 33)]
    assert max(lag) < 0.08  # the AR(2) itself: 0.99, 0.97, …


def test_whitening_is_the_exact_gaussian_likelihood_of_the_model() -> None:
    rng = np.random.default_rng(2)
    model = fit_noise_ar(_ar2(2000, rng, white=0.5), 8)
    assert model is not None and model.order >= 2
    n = 300
    cov = toeplitz(_acov(model, n))
    r = rng.normal(0.0, 1.0, n)
    w = model.whiten(r)
    assert float(w @ w) == pytest.approx(float(r @ np.linalg.solve(cov, r)), rel=1e-6)


@pytest.mark.parametrize(
    ("x", "why"),
    [
        (np.random.default_rng(3).normal(0.0, 0.01, 400), "white noise"),
        (np.zeros(400), "a constant"),
        (_ar2(15, np.random.default_rng(4)), "too short to identify"),
        (np.r_[_ar2(399, np.random.default_rng(5)), math.nan], "not finite"),
    ],
)
def test_no_model_where_the_noise_is_white_or_not_identifiable(x: np.ndarray, why: str) -> None:
    assert fit_noise_ar(x, 12) is None, why


def test_order_zero_means_ordinary_least_squares() -> None:
    assert fit_noise_ar(_ar2(400, np.random.default_rng(6)), 0) is None


def test_the_whitened_fit_finds_the_decay_rate_under_drifting_riding_better() -> None:
    """A slow drift (AR(1), φ 0.98) the fit's constant cannot absorb: generalised least squares wins (seeded)."""
    rng = np.random.default_rng(7)
    tt = np.arange(0.0, 3.0, 1.0 / RATE)
    truth = np.array([0.0, -1.0, 2.0 * math.pi * FREQ, 0.4, 0.0])
    errors: dict[str, list[float]] = {"ols": [], "gls": []}
    for _ in range(40):
        drift = np.asarray(lfilter([1.0], [1.0, -0.98], rng.normal(0.0, 0.01, 2000 + 100 + tt.size)), dtype=float)
        model = fit_noise_ar(drift[2000:2100], 12)
        assert model is not None
        y = seg_mod._decay_model(truth, tt) + drift[2100:]
        for name, ar in (("ols", None), ("gls", model)):
            fit = seg_mod._fit_decay(tt, y, truth, ar)
            assert fit is not None
            errors[name].append(float(fit[1] - truth[1]))
    rms = {k: math.sqrt(float(np.mean(np.square(v)))) for k, v in errors.items()}
    assert rms["gls"] < rms["ols"], rms


def test_without_a_model_the_fit_is_ordinary_least_squares() -> None:
    rng = np.random.default_rng(8)
    tt = np.arange(0.0, 2.0, 1.0 / RATE)
    truth = np.array([0.01, -1.2, 9.0, 0.3, -0.1])
    y = seg_mod._decay_model(truth, tt) + rng.normal(0.0, 0.01, tt.size)
    white = NoiseAR(np.empty(0), 1.0, np.empty(0))  # order 0: the identity
    plain, whitened = seg_mod._fit_decay(tt, y, truth), seg_mod._fit_decay(tt, y, truth, white)
    assert plain is not None and whitened is not None
    assert whitened == pytest.approx(plain, rel=1e-6, abs=1e-9)
    assert plain[1] == pytest.approx(truth[1], abs=0.1)


@cache
def _raw_log() -> SimulatedLog:
    ms = canonical_with_sigma(
        add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    )
    plan = RideLog(32.0, 3.33, starts=(-7.0,), pushes=(8.0, 20.0))  # riding at speed from the start
    return simulate_raw_log(ms.matrices, ms.g, plan, np.random.default_rng(11))


def test_a_raw_log_segment_is_fitted_whitened_by_its_riding() -> None:
    log = _raw_log()
    record = RideRecord("log", log.times, log.roll_rate, speed=log.wheel_speed)
    whitened = segment_record(record).segments
    plain = segment_record(record, SegmentOptions(noise_order=0)).segments
    assert [s.kick.onset for s in whitened] == [s.kick.onset for s in plain]
    assert len(whitened) == len(log.pushes)
    assert all("whitened by the riding's AR(" in s.stop_reason for s in whitened)
    assert not any("whitened" in s.stop_reason for s in plain)


def test_unevenly_sampled_riding_is_fitted_by_ordinary_least_squares() -> None:
    log = _raw_log()
    jitter = np.random.default_rng(12).uniform(-0.3, 0.3, log.times.size) * float(np.diff(log.times[:2])[0])
    record = RideRecord("log", log.times + jitter, log.roll_rate, speed=log.wheel_speed)
    segments = segment_record(record).segments
    assert len(segments) == len(log.pushes)
    assert not any("whitened" in s.stop_reason for s in segments)
