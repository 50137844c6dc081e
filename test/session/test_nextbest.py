"""The next-best measurement on simulated Browser sessions: rankings, and predictions checked by measuring again.

Each test simulates one Browser session (``config/rig.yaml``, the truth from
``config/bicycles/browser.yaml``) with a fresh seed, printed; ``BIKE_RIG_TEST_SEED`` repeats it.
The coupled swing is switched off: a beating trial is flagged and left out, which could leave a
period without a usable trial, and beating is not what these tests are about.
"""

from __future__ import annotations

import dataclasses
import math
import os
import secrets
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.measurements import Measurements, Reading
from bike_rig.core.period import PeriodFit, combine_periods, fit_period
from bike_rig.core.sim import SimulatedSession, load_rig, load_true_parameters, simulate_session
from bike_rig.pipeline.model import compute_model
from bike_rig.pipeline.offline import DEFAULT_SPEEDS
from bike_rig.session.nextbest import (
    READING,
    TRIAL,
    NextBestError,
    PeriodTrials,
    next_best,
    nominal_reading_sigmas,
    sigma_after_one_more_trial,
)


@pytest.fixture
def seed() -> int:
    fixed = os.environ.get("BIKE_RIG_TEST_SEED")
    value = int(fixed) if fixed else secrets.randbelow(2**32)
    print(f"seed = {value} (BIKE_RIG_TEST_SEED={value} repeats this run)")
    return value


@dataclass
class Simulated:
    """A simulated session with every trial fitted."""

    session: SimulatedSession
    fits: dict[str, list[PeriodFit]]
    nominal: dict[str, float]

    def measurements(self, fits: Mapping[str, list[PeriodFit]] | None = None) -> Measurements:
        combined = {k: combine_periods(f) for k, f in (fits or self.fits).items()}
        return self.session.measurements({k: (c.value, c.sigma) for k, c in combined.items()})

    def trials(self, fits: Mapping[str, list[PeriodFit]] | None = None) -> dict[str, PeriodTrials]:
        """Each key's usable trials (a flagged one, e.g. a poor fit, is left out as combine_periods does)."""
        return {
            k: PeriodTrials(tuple(f.period_sigma for f in fl if f.valid and not f.flags))
            for k, fl in (fits or self.fits).items()
        }

    def items(self) -> list[str]:
        """Every reading (counts aside) and every period, in plan order."""
        readings = [k for k in self.session.readings if k not in ("nR", "nF")]
        return readings + [m.key for m in self.session.plan]


def _simulate(seed: int) -> Simulated:
    rig = load_rig(config_file("rig.yaml"))
    rig = dataclasses.replace(rig, coupled_swing=None)
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    s = simulate_session(truth, rig, seed, name)
    fits: dict[str, list[PeriodFit]] = {}
    for t in s.trials:
        fits.setdefault(t.key, []).append(fit_period(t.rate, sample_rate_hz=t.sample_rate))
    assert all(combine_periods(fl).n_used > 0 for fl in fits.values())
    return Simulated(s, fits, nominal_reading_sigmas(rig.sigma, list(s.readings)))


def _weave_capsize(m: Measurements, rider: str = "") -> tuple[float, float]:
    """The speeds' σ as the model node, the demo and replay compute them."""
    _, stability = compute_model(compute_parameters(m), DEFAULT_SPEEDS, rider)
    assert stability.weave is not None and stability.capsize is not None
    return stability.weave.sigma, stability.capsize.sigma


def _with(m: Measurements, key: str, value: float, sigma: float) -> Measurements:
    readings = dict(m.readings)
    readings[key] = Reading(value, sigma)
    return dataclasses.replace(m, readings=readings)


@pytest.mark.parametrize("key", ["mF", "gamma", "aH3", "alphaH2"])
def test_a_poor_reading_ranks_first_and_taking_it_again_reduces_the_weave_sigma_as_predicted(
    seed: int, key: str
) -> None:
    """One reading with σ 10-20× nominal, perturbed within that σ; retaken at nominal σ from the truth + noise.

    Over 234 sessions per key (and 60 more with w and mR) it always ranked first, and the
    actual reduction of the weave speed's σ was 0.956-55 times the predicted one (the large
    ratios where the poor head-tube angle hardly moves the weave speed's σ); the test asks for
    at least 0.9 times.
    """
    sim = _simulate(seed)
    rng = np.random.default_rng(seed)
    truth = sim.session.truth.static[key]
    poor_sigma = sim.nominal[key] * rng.uniform(10.0, 20.0)
    poor = _with(sim.measurements(), key, truth + poor_sigma * float(np.clip(rng.standard_normal(), -1, 1)), poor_sigma)

    ranked = next_best(poor, sim.items(), sim.nominal, sim.trials())
    top = ranked[0]
    assert (top.key, top.kind, top.missing) == (key, READING, False)
    assert top.sigma == poor_sigma and top.sigma_after == sim.nominal[key]
    assert len(ranked) == len(sim.items()) and {s.key for s in ranked} == set(sim.items())
    assert [s.score for s in ranked] == sorted((s.score for s in ranked), reverse=True)
    # the current σ is the model's, to round-off: the prediction starts from the same numbers
    weave, capsize = _weave_capsize(poor)
    assert top.weave_sigma == pytest.approx(weave, rel=1e-9)
    assert top.capsize_sigma == pytest.approx(capsize, rel=1e-9)
    assert top.weave_reduction > 0 and top.capsize_reduction > 0

    retaken = _with(poor, key, truth + sim.nominal[key] * rng.standard_normal(), sim.nominal[key])
    weave_after, _ = _weave_capsize(retaken)
    actual = weave - weave_after
    print(f"{key}: predicted {top.weave_reduction:.4g} m/s, actual {actual:.4g} m/s")
    assert actual >= 0.9 * top.weave_reduction


def test_the_prediction_carries_the_riders_sensitivities(seed: int) -> None:
    sim = _simulate(seed)
    m = _with(sim.measurements(), "gamma", sim.session.truth.static["gamma"], 15 * sim.nominal["gamma"])
    ranked = next_best(m, sim.items(), sim.nominal, sim.trials(), rider="paper")
    weave, capsize = _weave_capsize(m, rider="paper")
    assert ranked[0].key == "gamma"
    assert ranked[0].weave_sigma == pytest.approx(weave, rel=1e-9)
    assert ranked[0].capsize_sigma == pytest.approx(capsize, rel=1e-9)
    without = next_best(m, sim.items(), sim.nominal, sim.trials())
    assert without[0].weave_sigma != pytest.approx(weave, rel=1e-3)


def test_a_period_with_one_noisy_trial_asks_for_one_more_trial(seed: int) -> None:
    """The fork's second orientation has one noisy trial, stopped after 6 cycles; every reading is at its nominal σ.

    The trial's rate carries extra white noise of 0.1 × its peak rate (a loose gyro mount) and
    it is fitted over 6 cycles after the 1 s lead-in; it stays usable (no flag in 750 sessions).
    Retaking a reading at its nominal σ gains nothing, so the ranking is among the trials: the
    noisy trial's key ranked first in 750 of 750 sessions measured. The prediction takes the
    next trial as typical of the key's trials so far (here the noisy one), so a whole clean next
    trial weighs more than predicted.
    """
    sim = _simulate(seed)
    key = "TtH2"
    first, second = sim.session.trials_of(key)[:2]
    peak = first.modes[0].amplitude * 2 * math.pi / first.modes[0].period  # rad/s
    noisy = first.rate + 0.1 * peak * np.random.default_rng(seed).standard_normal(first.rate.shape[0])
    n = int((1.0 + 6 * sim.session.truth.periods[key]) * first.sample_rate)
    short = fit_period(noisy[:n], sample_rate_hz=first.sample_rate)
    assert short.valid and not short.flags
    fits = dict(sim.fits)
    fits[key] = [short]
    m = sim.measurements(fits)

    ranked = next_best(m, sim.items(), sim.nominal, sim.trials(fits))
    top = ranked[0]
    assert (top.key, top.kind) == (key, TRIAL)
    assert top.sigma == short.period_sigma
    assert top.sigma_after == pytest.approx(short.period_sigma / math.sqrt(2), rel=1e-12)
    # the capsize speed (a0 = det(g K0 + v² K2) = 0) depends on no inertia but the wheels' spin
    assert top.weave_reduction > 0 and top.capsize_reduction == 0
    readings = [s for s in ranked if s.kind == READING]
    assert readings and all(abs(s.score) < 1e-9 for s in readings)
    assert ranked.index(readings[0]) > max(i for i, s in enumerate(ranked) if s.kind == TRIAL and s.score > 1e-9)

    # the weights' part of the prediction; whether the two trials will scatter (a Birge ratio
    # above 1, 3 % of sessions here) cannot be known before the trial, nor whether the whole
    # trial's ends will depart from its law by chance and widen its σ (a note says so)
    whole = fit_period(second.rate, sample_rate_hz=second.sample_rate)
    fits[key] = [short, whole]
    if whole.period_sigma <= short.period_sigma:
        assert combine_periods(fits[key]).sigma_internal <= top.sigma_after
    else:
        assert any("is widened to" in note for note in whole.notes), whole.notes


def test_one_more_trial_is_combined_as_the_trials_are(seed: int) -> None:
    """Predicted σ against combine_periods with the new trial at the combined value (its expected place).

    Trials that agree (Birge ratio ≤ 1) give exactly the prediction; trials that scatter keep
    their Birge inflation in the prediction, which combine_periods then spreads over one more
    degree of freedom: the prediction is an upper bound there.
    """
    sim = _simulate(seed)
    base = sim.fits["TcR1"][0]
    rng = np.random.default_rng(seed)
    sigmas = [float(s) for s in rng.uniform(1e-5, 4e-5, 3)]
    typical = float(rng.uniform(1e-5, 4e-5))
    for spread in (0.01, 5.0):
        periods = [1.36 + spread * s * float(z) for s, z in zip(sigmas, rng.standard_normal(3))]
        trials = [dataclasses.replace(base, period=t, period_sigma=s) for t, s in zip(periods, sigmas)]
        now = combine_periods(trials)
        new = dataclasses.replace(base, period=now.value, period_sigma=typical)
        actual = combine_periods([*trials, new]).sigma
        predicted = sigma_after_one_more_trial(now.sigma, sigmas, typical)
        if now.birge_ratio <= 1.0:
            assert predicted == pytest.approx(actual, rel=1e-12)
        else:
            assert actual < predicted <= now.sigma
    # only the combined σ and the count known: as many equal trials
    assert sigma_after_one_more_trial(2e-5, PeriodTrials.from_count(2e-5, 3).sigmas, 2e-5 * math.sqrt(3)) == (
        pytest.approx(2e-5 * math.sqrt(3 / 4), rel=1e-12)
    )


def test_while_incomplete_the_missing_items_come_first_in_plan_order(seed: int) -> None:
    sim = _simulate(seed)
    complete = sim.measurements()
    readings = {k: r for k, r in complete.readings.items() if k not in ("gamma", "TtB2", "TcR1")}
    readings["TtH1"] = Reading(math.nan, math.nan)  # a period whose only trial gave none
    m = dataclasses.replace(complete, readings=readings)
    items = [k for k in sim.items() if k != "TcR1"]  # TcR1 missing yet not offered: still listed, after

    ranked = next_best(m, items, sim.nominal, sim.trials())
    missing = [s for s in ranked if s.missing]
    assert [s.key for s in missing] == ["gamma", "TtB2", "TtH1", "TcR1"]
    assert ranked[: len(missing)] == tuple(missing)
    assert all(s.sigma == math.inf and s.score == math.inf for s in missing)
    assert [s.kind for s in missing] == [READING, TRIAL, TRIAL, TRIAL]
    rest = ranked[len(missing) :]
    assert [s.key for s in rest] == [k for k in items if k not in ("gamma", "TtB2", "TtH1")]
    assert all(math.isnan(s.score) and math.isnan(s.weave_sigma_after) for s in rest)
    assert "missing" in missing[0].describe() and "once the parameters are complete" in rest[0].describe()


def test_an_item_without_a_nominal_sigma_is_an_error_naming_it(seed: int) -> None:
    sim = _simulate(seed)
    nominal = {k: v for k, v in sim.nominal.items() if k != "mF"}
    with pytest.raises(NextBestError, match="reading 'mF': no nominal σ"):
        next_best(sim.measurements(), sim.items(), nominal, sim.trials())
    # trial item ids count as their key, once
    ranked = next_best(sim.measurements(), ["TtB2#1", "TtB2#3", "mF"], sim.nominal)
    assert [s.key for s in ranked] == ["TtB2", "mF"]  # mF is at its nominal σ: nothing to gain
    line = ranked[0].describe()
    assert line.startswith("TtB2 (one more trial): σ") and "weave σ" in line and "capsize σ" in line
    assert "\n" not in line
