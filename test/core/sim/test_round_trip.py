"""Round trip and calibration: simulate → fit every trial → science core → the truth.

Browser sessions (the paper's Table 2, column B, g = 9.81) on the shipped rig without the
coupled swing (beating trials are the fitter's to flag, not an error to average), every
trial fitted with :func:`~bike_rig.core.period.fit_period`, each period's three trials
combined with :func:`~bike_rig.core.period.combine_periods`, the 25 parameters computed with
:func:`~bike_rig.core.benchmark.compute_parameters`. Everything stays in memory.

Each test must pass for any seed. The failure probabilities below assume that the pipeline
is right: every reported σ honest and the errors normal (the parameters: linear propagation,
checked by the core's own tests against Monte Carlo). The fitted periods are compared with
the damped period (Eq 25, what the fitter estimates); the parameters with the truth, which
the paper's formulas reach from damped periods only up to ζ²/2 = 5e-7 relative, far below σ.
"""

from __future__ import annotations

import os
import secrets
from dataclasses import dataclass, replace

import numpy as np
import pytest
from numpy.typing import NDArray

from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.period import combine_periods, fit_period
from bike_rig.core.sim.rig import RigConfig
from bike_rig.core.sim.session import SimulatedSession, simulate_session
from bike_rig.core.symbols import PARAMETER_NAMES

#: Sessions pooled by the calibration tests (the issue asks for at least 50).
SESSIONS = 50
#: The 25 benchmark parameters (g is a reading, not one of them).
PARAMETERS = tuple(k for k in PARAMETER_NAMES if k != "g")


@dataclass(frozen=True)
class Recovered:
    """Normalised errors (estimate − truth) / reported σ of one session's results."""

    trials: NDArray[np.float64]  # (39,) every trial's fitted period (NaN when the fit has none)
    periods: NDArray[np.float64]  # (13,) every combined period
    parameters: NDArray[np.float64]  # (25,) the benchmark parameters
    flags: int  # trials the fitter flagged or found invalid


def recover(session: SimulatedSession) -> Recovered:
    """Fit, combine and compute one session, and compare with its truth."""
    trial_z, period_z, periods, flags = [], [], {}, 0
    for m in session.plan:
        truth = session.truth.damped_periods[m.key]
        fits = [fit_period(t.rate, sample_rate_hz=t.sample_rate) for t in session.trials_of(m.key)]
        flags += sum(1 for f in fits if f.flags or not f.valid)
        trial_z += [(f.period - truth) / f.period_sigma for f in fits]
        combined = combine_periods(fits)
        period_z.append((combined.value - truth) / combined.sigma)
        periods[m.key] = (combined.value, combined.sigma)
    ps = compute_parameters(session.measurements(periods)).parameters
    param_z = [(ps.value(k) - session.truth.parameters[k]) / ps.sigma(k) for k in PARAMETERS]
    return Recovered(np.array(trial_z), np.array(period_z), np.array(param_z), flags)


@pytest.fixture(scope="module")
def base_seed() -> int:
    fixed = os.environ.get("BIKE_RIG_TEST_SEED")
    value = int(fixed) if fixed else secrets.randbelow(2**32)
    print(f"base seed = {value} (BIKE_RIG_TEST_SEED={value} repeats this run)")
    return value


@pytest.fixture(scope="module")
def quiet_rig(rig: RigConfig) -> RigConfig:
    """The shipped rig without the coupled swing mode."""
    return replace(rig, coupled_swing=None)


@pytest.fixture(scope="module")
def recovered(quiet_rig: RigConfig, browser_truth: dict[str, float], base_seed: int) -> list[Recovered]:
    """:data:`SESSIONS` independent Browser sessions, recovered."""
    return [recover(simulate_session(browser_truth, quiet_rig, base_seed + i, "Browser")) for i in range(SESSIONS)]


def test_round_trip_browser_session(recovered: list[Recovered]) -> None:
    """Every parameter and period comes back within its σ of the truth.

    * One session: the 25 parameters within 5σ (probability 1.4e-5 that one leaves; at 4σ it
      would be 1.6e-3). Its periods are pooled below instead: the fitter's σ has heavier tails
      than a normal σ (measured over 300 sessions: 1.9e-3 of the trial fits beyond 4σ, normal
      6.3e-5), so a per-session bound on 52 periods would fail a few runs in a hundred.
    * All 50 sessions pooled, the 25 parameters, 13 combined periods and 39 trial periods of
      each (3 850 values): at least 90 % within 2σ (95.4 % expected; the pooled fraction's
      standard deviation, correlations within a session included, is 0.44 %, so 90 % is 12 of
      them away) and at least 99.5 % within 4σ (at the measured tail rates 4 values beyond 4σ
      are expected, 20 or more have a Poisson probability of 2e-8).
    * At most 2 % of the trials flagged by the fitter (clean data; measured 0.24 %: 5 expected,
      39 or more have a Poisson probability below 1e-20).
    """
    first = recovered[0].parameters
    assert np.all(np.abs(first) < 5.0), dict(zip(PARAMETERS, first.round(2)))
    pooled = np.concatenate([np.concatenate([r.parameters, r.periods, r.trials]) for r in recovered])
    assert pooled.shape == (SESSIONS * 77,)
    within2, within4 = float(np.mean(np.abs(pooled) < 2.0)), float(np.mean(np.abs(pooled) < 4.0))
    flagged = sum(r.flags for r in recovered) / (SESSIONS * 39)
    print(
        f"first session: parameters max |z| {np.max(np.abs(first)):.2f}; pooled over {SESSIONS} sessions: "
        f"{within4:.2%} within 4σ, {within2:.1%} within 2σ, max |z| {np.max(np.abs(pooled)):.2f}; "
        f"sessions with every value within 4σ: "
        f"{np.mean([np.all(np.abs(np.concatenate([r.parameters, r.periods, r.trials])) < 4) for r in recovered]):.0%}; "
        f"flagged trials {flagged:.2%}"
    )
    assert within2 >= 0.90
    assert within4 >= 0.995
    assert flagged <= 0.02


def test_period_sigmas_are_calibrated(recovered: list[Recovered]) -> None:
    """The 1σ interval of each of the 50 × 39 = 1 950 independent trial fits contains the truth in 60–90 % of them.

    For honest σ (68.3 %) the binomial count falls below 60 % with probability 1e-14; the check of
    the phase at the window's ends (:mod:`bike_rig.core.period.ends`) widens the σ of the third
    of trials whose ends depart from the fit by more than their σ, to about 82 % (at most 90 %).
    """
    trials = np.concatenate([r.trials for r in recovered])
    periods = np.concatenate([r.periods for r in recovered])
    assert trials.shape == (SESSIONS * 39,)
    coverage = float(np.mean(np.abs(trials) < 1.0))
    print(f"trial periods: {coverage:.1%} within 1σ; combined periods: {np.mean(np.abs(periods) < 1.0):.1%}")
    assert 0.60 <= coverage <= 0.90


def test_parameter_sigmas_are_calibrated(recovered: list[Recovered]) -> None:
    """The 1σ intervals of the 25 parameters over 50 sessions contain the truth in 55–80 % of the 1 250 cases.

    Within a session the parameters are correlated: the per-session coverage has a standard
    deviation of ≈ 0.14 (measured over 60 sessions), so the mean of 50 has ≈ 0.019, and 55 % and
    80 % are 6.9 and 6.0 of those from 68.3 %: probability 7e-10.
    """
    z = np.stack([r.parameters for r in recovered])
    coverage = float(np.mean(np.abs(z) < 1.0))
    print(
        f"parameters: {coverage:.1%} within 1σ; per parameter: "
        + ", ".join(f"{k} {c:.0%}" for k, c in zip(PARAMETERS, np.mean(np.abs(z) < 1.0, axis=0)))
    )
    assert 0.55 <= coverage <= 0.80
