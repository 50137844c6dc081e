"""A compound pendulum's finite swing through the whole chain: the rig, the fit, the parameters.

Browser sessions on the shipped rig (no coupled swing) with compound pendulums swinging 6–10°
as the sin θ pendulum they are (``trials.finite_swing``) and a dry friction of up to 2 % of the
swing per cycle: the fitted period is the period at the window centre's swing, 0.1–0.2 % longer
than the small-swing period the paper's formulas assume. With the option
``small_swing_period`` the fit reports the small-swing period, and the compound periods, and the
parameters computed from them, come back within their σ; without it the compound periods are
biased by many σ, and the uncertainty budget states the shift as a systematic line.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.period import combine_periods, fit_period
from bike_rig.core.period.small_swing import SMALL_SWING_SOURCE, small_swing_parts
from bike_rig.core.sim.rig import RigConfig
from bike_rig.core.sim.session import SimulatedSession, simulate_session
from bike_rig.core.uncertainty.budget import uncertainty_budget
from bike_rig.pipeline.fit import TrialFit
from bike_rig.pipeline.offline import SessionTrial
from bike_rig.pipeline.swing import TO_SMALL, swing_alternative

SEEDS = (11, 12)


@pytest.fixture(scope="module")
def swinging_rig(rig: RigConfig) -> RigConfig:
    trials = replace(rig.trials, amplitude_deg=(6.0, 10.0), finite_swing=True, dry_friction=(0.0, 0.02))
    return replace(rig, coupled_swing=None, trials=trials)


@pytest.fixture(scope="module")
def sessions(swinging_rig: RigConfig, browser_truth: dict[str, float]) -> list[SimulatedSession]:
    return [simulate_session(browser_truth, swinging_rig, seed, "Browser") for seed in SEEDS]


def _compound(session: SimulatedSession) -> list[str]:
    return [m.key for m in session.plan if m.pendulum == "compound"]


Periods = tuple[dict[str, tuple[float, float]], list[SessionTrial]]


@pytest.fixture(scope="module")
def fitted(sessions: list[SimulatedSession]) -> dict[tuple[int, bool], Periods]:
    """:func:`_periods` of each session (by its index) with and without the small-swing option."""
    return {(i, small): _periods(s, small) for i, s in enumerate(sessions) for small in (False, True)}


def _periods(session: SimulatedSession, small: bool) -> Periods:
    periods, trials = {}, []
    for m in session.plan:
        fits = [
            fit_period(t.rate, sample_rate_hz=t.sample_rate, small_swing_period=small) for t in session.trials_of(m.key)
        ]
        combined = combine_periods(fits)
        periods[m.key] = (combined.value, combined.sigma)
        trials += [SessionTrial(TrialFit(f"{m.key}-{i}", m.key, f), used=f.clean) for i, f in enumerate(fits)]
    return periods, trials


def test_the_small_swing_period_option_recovers_the_truth(
    sessions: list[SimulatedSession], fitted: dict[tuple[int, bool], Periods]
) -> None:
    for i, session in enumerate(sessions):
        keys = _compound(session)
        at_centre, _ = fitted[i, False]
        small, _ = fitted[i, True]
        truth = session.truth.damped_periods
        z_small = np.array([(small[k][0] - truth[k]) / small[k][1] for k in keys])
        z_fitted = np.array([(at_centre[k][0] - truth[k]) / at_centre[k][1] for k in keys])
        assert np.all(np.abs(z_small) < 4.5), z_small
        assert np.mean(z_fitted) > 5 and np.all(z_fitted > 0), z_fitted  # the swing lengthens the period
        # the torsional periods do not follow the swing: the same either way
        others = [m.key for m in session.plan if m.key not in keys]
        assert all(at_centre[k] == small[k] for k in others)
        ps = compute_parameters(session.measurements(small)).parameters
        z = [(ps.value(k) - session.truth.parameters[k]) / ps.sigma(k) for k in ps.names if k != "g"]
        assert np.max(np.abs(z)) < 5, z


def test_the_budget_states_the_swing_as_a_systematic_line(
    sessions: list[SimulatedSession], fitted: dict[tuple[int, bool], Periods]
) -> None:
    session = sessions[0]
    periods, trials = fitted[0, False]
    alternative = swing_alternative(trials)
    shifts = alternative[TO_SMALL]
    assert set(shifts) <= set(_compound(session)) and shifts
    assert all(-0.005 * periods[k][0] < v < 0 for k, v in shifts.items())  # the small swing: shorter
    ps = compute_parameters(session.measurements(periods))
    budget = uncertainty_budget(ps, None, alternative)
    line = budget.output("IFyy").systematic  # (a wheel's spin inertia: its compound period)
    assert len(line) == 1 and line[0].source == TO_SMALL and line[0].shift < 0.0
    assert budget.output("mB").systematic[0].shift == 0.0  # a mass does not depend on a period
    # the shift is the first-order change of the output: the parameters recomputed agree
    moved = {k: (v - shifts.get(k, 0.0), s) for k, (v, s) in periods.items()}
    again = compute_parameters(session.measurements(moved)).parameters
    for name in ("IBxx", "IFxx", "IRyy", "mB"):
        delta = again.value(name) - ps.parameters.value(name)
        shift = budget.output(name).systematic[0].shift
        assert shift == pytest.approx(-delta, rel=0.05, abs=1e-9 * max(1.0, abs(ps.parameters.value(name))))


def test_the_budget_shows_the_small_swing_systematic_as_a_line(
    sessions: list[SimulatedSession], fitted: dict[tuple[int, bool], Periods]
) -> None:
    session = sessions[0]
    periods, trials = fitted[0, True]
    parts = small_swing_parts((t.key, t.result.fit) for t in trials if t.used)
    assert parts, "no compound period of the session has a small-swing systematic"
    by_key = parts[SMALL_SWING_SOURCE]
    assert set(by_key) <= set(_compound(session))
    assert all(0 < v < periods[k][1] for k, v in by_key.items())  # (a part of the combined σ)
    ps = compute_parameters(session.measurements(periods))
    budget = uncertainty_budget(ps, None, None, None, parts)
    lines = [s for o in budget.outputs for s in o.shares if s.input.endswith(f"({SMALL_SWING_SOURCE})")]
    assert lines and all(s.key in by_key for s in lines)
