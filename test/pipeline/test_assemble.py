"""core/assembly: static readings + period estimates → the parameter set; the model products."""

from __future__ import annotations

import dataclasses
import math
import random
from pathlib import Path

import numpy as np
import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import ComMethod, ParameterSet, compute_parameters
from bike_rig.core.errors import GeometryError, MeasurementError, ModelError
from bike_rig.core.loader import load_measurements, load_static_readings
from bike_rig.core.measurements import Measurements, Reading
from bike_rig.core.period import combine_periods
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.uncertainty.matrix_sigma import SigmaConvention, canonical_with_sigma
from bike_rig.core.whipple import critical_speeds, eigenvalues, state_space
from bike_rig.pipeline.assemble import (
    SessionAssembly,
    SessionParameters,
    assemble,
    combine_trials,
    required_period_keys,
)
from bike_rig.pipeline.errors import AssemblyError, FlagCodeError
from bike_rig.pipeline.fit import TrialFit
from bike_rig.pipeline.fit_details import FitDetails
from bike_rig.pipeline.model import compute_model, state_space_at
from test.support.nodes import BROWSER_KEYS

BICYCLES = ("browser", "browserins", "crescendo", "fisher", "stratos", "yellow")


def bicycle(name: str) -> Path:
    return config_file(f"bicycles/{name}.yaml")


def file_trials(full: Measurements, keys: tuple[str, ...]) -> list[TrialFit]:
    """One trial per key carrying the file's own period and σ."""
    return [TrialFit.from_period(f"{k}-t1", k, full.value(k), full.readings[k].sigma, True) for k in keys]


def assert_same_set(got: ParameterSet | None, expected: ParameterSet | None) -> None:
    assert got is not None and expected is not None
    gp, ep = got.parameters, expected.parameters
    assert gp.names == ep.names
    assert np.array_equal(gp.values, ep.values)
    assert np.array_equal(gp.covariance, ep.covariance)


@pytest.mark.parametrize("name", BICYCLES)
def test_file_periods_as_trials_give_the_files_parameters_exactly(name: str) -> None:
    full = load_measurements(bicycle(name))
    session = SessionAssembly(load_static_readings(bicycle(name)))
    session.add_all(file_trials(full, session.required_keys))
    result = session.result()
    assert result.complete and result.missing == ()
    assert result.parameters is not None
    assert_same_set(result.parameters, compute_parameters(full))
    assert [(p.key, p.value, p.sigma, p.trial_ids) for p in result.periods] == [
        (k, full.value(k), full.readings[k].sigma, (f"{k}-t1",)) for k in session.required_keys
    ]


def test_com_method_is_passed_on() -> None:
    full = load_measurements(bicycle("browser"))
    session = SessionAssembly(load_static_readings(bicycle("browser")), ComMethod.LEAST_SQUARES)
    session.add_all(file_trials(full, session.required_keys))
    result = session.result()
    assert result.com_method is ComMethod.LEAST_SQUARES
    assert_same_set(result.parameters, compute_parameters(full, ComMethod.LEAST_SQUARES))


def test_required_keys_follow_from_the_static_readings() -> None:
    static = load_static_readings(bicycle("browser"))
    assert required_period_keys(static) == BROWSER_KEYS
    # a fourth frame orientation asks for a fourth frame torsional period
    readings = dict(static.readings)
    readings["alphaB4"] = Reading(60.0, 0.2)
    readings["aB4"] = Reading(0.01, 0.003)
    four = Measurements(static.bicycle, readings, static.path)
    keys = SessionAssembly(four).required_keys
    assert "TtB4" in keys and len(keys) == len(BROWSER_KEYS) + 1


def test_missing_keys_listed_in_canonical_order() -> None:
    full = load_measurements(bicycle("browser"))
    session = SessionAssembly(load_static_readings(bicycle("browser")))
    assert session.result().missing == BROWSER_KEYS
    have = ("TtB2", "TcR1", "TtP1", "TtH3")
    session.add_all(file_trials(full, have))
    result = session.result()
    assert not result.complete and result.parameters is None
    assert result.missing == tuple(k for k in BROWSER_KEYS if k not in have)
    assert [p.key for p in result.periods] == ["TtP1", "TcR1", "TtB2", "TtH3"]


def trial_set(full: Measurements, keys: tuple[str, ...], seed: int) -> list[TrialFit]:
    """Three scattered trials per key, with distinct ids."""
    rng = np.random.default_rng(seed)
    out = []
    for k in keys:
        v, s = full.value(k), full.readings[k].sigma
        for i in range(3):
            out.append(TrialFit.from_period(f"{k}-{i}", k, v + s * rng.normal(), s * (1 + 0.5 * rng.random()), True))
    return out


def test_any_order_gives_identical_floats() -> None:
    full = load_measurements(bicycle("browser"))
    static = load_static_readings(bicycle("browser"))
    trials = trial_set(full, BROWSER_KEYS, seed=1)
    reference = assemble(static, trials)
    shuffler = random.Random(7)
    for _ in range(5):
        shuffled = trials[:]
        shuffler.shuffle(shuffled)
        again = assemble(static, shuffled)
        assert again.periods == reference.periods
        assert_same_set(again.parameters, reference.parameters)


def test_combination_is_combine_periods_in_trial_id_order() -> None:
    full = load_measurements(bicycle("browser"))
    trials = trial_set(full, ("TtB1",), seed=3)
    combined, used = combine_trials(reversed(trials))

    expected = combine_periods([t.fit for t in sorted(trials, key=lambda t: t.trial_id)])
    assert (combined.value, combined.sigma, combined.n_used) == (expected.value, expected.sigma, 3)
    assert used == ("TtB1-0", "TtB1-1", "TtB1-2")


def test_same_trial_id_replaces_the_earlier_estimate() -> None:
    full = load_measurements(bicycle("browser"))
    session = SessionAssembly(load_static_readings(bicycle("browser")))
    session.add_all(file_trials(full, BROWSER_KEYS))
    first = session.result()
    wrong = TrialFit.from_period("TtB1-t1", "TtB1", 2.5, 1e-4, True)
    session.add(wrong)
    assert session.result().periods[6].value == 2.5
    assert session.add(TrialFit.from_period("TtB1-t1", "TtB1", full.value("TtB1"), full.readings["TtB1"].sigma, True))
    assert len(session.trials) == len(BROWSER_KEYS)
    assert_same_set(session.result().parameters, first.parameters)
    # an identical re-publication changes nothing
    assert not session.add(session.trials[0])


def test_flagged_and_invalid_trials_are_left_out() -> None:
    full = load_measurements(bicycle("browser"))
    static = load_static_readings(bicycle("browser"))
    clean = file_trials(full, BROWSER_KEYS)
    bad = [
        TrialFit.from_period("TtB1-t2", "TtB1", 2.3, 1e-5, True, ("beating",), ("envelope modulation 5 %",)),
        TrialFit.from_period("TtB1-t3", "TtB1", math.nan, math.nan, False, ("no_oscillation",), ("flat",)),
        TrialFit.from_period("TtB1-t4", "TtB1", 2.2, 1e-5, False),
        TrialFit.from_period("TtB1-t5", "TtB1", 2.2, 0.0, True),  # no usable σ
    ]
    result = assemble(static, clean + bad)
    assert_same_set(result.parameters, compute_parameters(full))
    tt_b1 = next(p for p in result.periods if p.key == "TtB1")
    assert tt_b1.trial_ids == ("TtB1-t1",)
    # only flagged trials for a key: it stays missing
    only_bad = assemble(static, [t for t in clean if t.measurement_key != "TtB1"] + bad)
    assert only_bad.missing == ("TtB1",)


def test_unknown_key_or_flag_is_rejected() -> None:
    session = SessionAssembly(load_static_readings(bicycle("browser")))
    with pytest.raises(AssemblyError, match="'TtB4' is not a period of Browser"):
        session.add(TrialFit.from_period("x", "TtB4", 2.0, 1e-4, True))
    with pytest.raises(FlagCodeError, match="unknown quality flag code 'wobbly'"):
        session.add(TrialFit.from_period("y", "TtB1", 2.0, 1e-4, True, ("wobbly",), ("?",)))
    assert session.trials == ()


def test_bad_static_readings_fail_when_the_session_starts() -> None:
    static = load_static_readings(bicycle("browser"))
    readings = {k: r for k, r in static.readings.items() if k != "mR"}
    with pytest.raises(MeasurementError, match="mR"):
        SessionAssembly(Measurements(static.bicycle, readings, static.path))
    readings = dict(static.readings)
    readings["alphaB2"] = readings["alphaB1"]
    with pytest.raises(GeometryError, match="parallel"):
        SessionAssembly(Measurements(static.bicycle, readings, static.path))


# ---------------------------------------------------------------------------- model products


@pytest.fixture(scope="module")
def browser_set() -> ParameterSet:
    return compute_parameters(load_measurements(bicycle("browser")))


@pytest.mark.parametrize(("rider", "convention"), [("", "correlated"), ("paper", "paper"), ("none", "correlated")])
def test_compute_model_is_the_core_chain(browser_set: ParameterSet, rider: str, convention: str) -> None:
    speeds = np.linspace(0.0, 10.0, 201)
    matrices, stability = compute_model(browser_set, speeds, rider, convention)
    ps = add_rider(browser_set, PAPER_RIDER) if rider == "paper" else browser_set
    ms = canonical_with_sigma(ps, SigmaConvention(convention))
    for name in ("M", "C1", "K0", "K2"):
        assert np.array_equal(getattr(matrices.matrices, name), getattr(ms.matrices, name))
        assert np.array_equal(getattr(matrices.sigma, name), getattr(ms.sigma, name))
    assert matrices.rider == ("paper" if rider == "paper" else "")
    assert matrices.bicycle == "Browser" and matrices.g == ms.g
    sweep = eigenvalues(ms.matrices, ms.g, speeds)
    assert np.array_equal(stability.sweep.eigenvalues, sweep.eigenvalues)
    cs = critical_speeds(ms.matrices, ms.g)
    assert stability.weave is not None and stability.capsize is not None
    assert (stability.weave.speed, stability.capsize.speed) == (cs.weave, cs.capsize)
    assert 0 < stability.weave.sigma < 0.5 and 0 < stability.capsize.sigma < 0.5


def test_state_space_at_a_speed(browser_set: ParameterSet) -> None:
    matrices, _ = compute_model(browser_set, [0.0])
    st = state_space_at(matrices, 5.0)
    a, b = state_space(matrices.matrices, 5.0, matrices.g)
    assert np.array_equal(st.a, a) and np.array_equal(st.b, b)
    assert np.array_equal(st.eigenvalues, eigenvalues(matrices.matrices, matrices.g, [5.0]).eigenvalues[0])
    assert st.labels == ("weave", "weave", "capsize", "caster")
    for bad in (-1.0, math.nan, math.inf):
        with pytest.raises(ModelError, match="speed must be"):
            state_space_at(matrices, bad)


def test_unknown_rider_is_a_model_error(browser_set: ParameterSet) -> None:
    with pytest.raises(ModelError, match="unknown rider 'tall'"):
        compute_model(browser_set, [1.0], "tall")


def test_a_refit_from_fewer_samples_never_replaces_a_complete_one() -> None:
    """A restarted fitter may re-publish an earlier trial from an incomplete history.

    The complete estimate stays, in either order of arrival.
    """
    static = load_static_readings(config_file("bicycles/browser.yaml"))
    full = TrialFit.from_period("t1", "TcR1", 1.3611, 4e-6, True, n_samples=30000, n_expected=30000)
    partial = dataclasses.replace(full, fit=dataclasses.replace(full.fit, period=1.37, valid=True), n_samples=12000)
    for order in ((full, partial), (partial, full)):
        a = SessionAssembly(static)
        for t in order:
            a.add(t)
        assert a.trials == (full,)


def test_state_space_at_labels_modes_as_the_sweep_does(browser_set: ParameterSet) -> None:
    """At 1 m/s the Browser's capsize and caster roots form a complex pair and the weave roots are real.

    The labels must be the tracked sweep's, not those of the structure at 1 m/s.
    """
    matrices, stability = compute_model(browser_set, np.linspace(0.0, 10.0, 201))
    for i in (10, 20, 50, 120):  # 0.5, 1, 2.5 and 6 m/s
        st = state_space_at(matrices, float(stability.sweep.speeds[i]))
        assert st.labels == stability.sweep.labels
        np.testing.assert_allclose(st.eigenvalues, stability.sweep.eigenvalues[i], rtol=1e-9, atol=1e-9)
    weave_at_1 = state_space_at(matrices, 1.0).eigenvalues[:2]
    assert np.all(weave_at_1.imag == 0) and np.all(weave_at_1.real > 0)  # two real unstable roots


@pytest.mark.parametrize(("period", "sigma"), [(1e308, 1e-4), (2e3, 0.1), (1e-5, 1e-9), (1.2, 1.2), (1.2, 5.0)])
def test_an_absurd_estimate_is_refused_and_blocks_nothing(period: float, sigma: float) -> None:
    """A rogue's (or a broken fitter's) period far outside any rig pendulum never enters the set."""
    full = load_measurements(bicycle("browser"))
    session = SessionAssembly(load_static_readings(bicycle("browser")))
    session.add_all(file_trials(full, session.required_keys))
    before = session.result()
    absurd = TrialFit.from_period("rogue-t1", "TcR1", period, sigma, True)
    assert absurd.usable  # it would enter the combination
    with pytest.raises(AssemblyError, match="is not a rig pendulum's"):
        session.add(absurd)
    after = session.result()
    assert after.complete
    assert_same_set(after.parameters, before.parameters)
    # the same trial id, well formed, is taken afterwards (nothing was remembered of the bad one)
    assert session.add(TrialFit.from_period("rogue-t1", "TcR1", full.value("TcR1"), 1e-4, True))


RIGID_SPLIT_KEYS = ("TcS1", "TtS1", "TtS2", "TtS3", "TtS4", "TtS5", "TcG1", "TtG1", "TtG2", "TtG3")


def test_refined_file_periods_as_trials_give_the_files_parameters_exactly() -> None:
    """The refined method (surface plate, fork S and handlebar G hung separately) through the live assembly."""
    full = load_measurements(bicycle("rigid"))
    static = load_static_readings(bicycle("rigid"))
    session = SessionAssembly(static)
    assert set(RIGID_SPLIT_KEYS) <= set(session.required_keys)
    assert not any(k.endswith("H1") or k.startswith("TtH") for k in session.required_keys)
    session.add_all(file_trials(full, session.required_keys))
    result = session.result()
    assert result.complete and result.missing == ()
    expected = compute_parameters(full)
    assert_same_set(result.parameters, expected)
    assert result.parameters is not None and result.parameters.parts is not None and expected.parts is not None
    assert np.array_equal(result.parameters.parts.values, expected.parts.values)


def test_refined_static_keys_are_required_by_the_method_in_use() -> None:
    static = load_static_readings(bicycle("rigid"))
    readings = {k: r for k, r in static.readings.items() if k != "h4"}
    cut = Measurements(static.bicycle, readings, static.path)
    with pytest.raises(MeasurementError, match="'h4': missing: the surface-plate geometry"):
        SessionAssembly(cut)
    missing = SessionAssembly(cut, partial=True).result().missing
    assert "h4" in missing
    assert "w" not in missing and "mH" not in missing and "TcH1" not in missing


def test_a_flywheel_is_measured_live_too() -> None:
    """A flywheel D's periods are asked for and its readings reach the parameters as from the file."""
    full = load_measurements(bicycle("browser"))
    extra = {"mD": Reading(full.value("mF") + 2.0, 0.01), "TcD1": Reading(1.5, 1e-5), "TtD1": Reading(0.8, 1e-5)}
    full = Measurements(full.bicycle, {**full.readings, **extra}, full.path)
    static = Measurements(full.bicycle, {k: r for k, r in full.readings.items() if not k.startswith("T")}, full.path)
    session = SessionAssembly(static)
    assert {"TcD1", "TtD1"} <= set(session.required_keys)
    session.add_all(file_trials(full, session.required_keys))
    result = session.result()
    assert result.complete and result.parameters is not None and result.parameters.parts is not None
    expected = compute_parameters(full).parts
    assert expected is not None
    assert result.parameters.parts.names == ("mD", "IDxx", "IDyy")
    assert np.allclose(result.parameters.parts.values, expected.values, rtol=1e-12, atol=0)


def _shared_systematic(trials: list[TrialFit], s_shared: float) -> list[FitDetails]:
    """Each trial's fit details with a small-swing systematic the key's trials share (the fitter's option)."""
    return [
        dataclasses.replace(FitDetails.of(t), small_swing_period=t.period, small_swing_systematic=s_shared)
        for t in trials
    ]


def _tcr1_trials(full: Measurements) -> list[TrialFit]:
    s = math.hypot(2e-5, 1e-4)
    return [
        TrialFit.from_period(f"TcR1-t{i}", "TcR1", full.value("TcR1") + d, s, True)
        for i, d in enumerate((-1e-5, 0, 1e-5))
    ]


@pytest.mark.parametrize("details_first", [True, False])
def test_fit_details_join_their_estimate_in_either_order(details_first: bool) -> None:
    """A trial's fit details are joined to its estimate whether they arrive before or after it."""
    full = load_measurements(bicycle("browser"))
    static = load_static_readings(bicycle("browser"))
    others = file_trials(full, tuple(k for k in BROWSER_KEYS if k != "TcR1"))
    tcr1 = _tcr1_trials(full)
    details = _shared_systematic(tcr1, 1e-4)
    with_details = [d.apply(t) for d, t in zip(details, tcr1, strict=True)]
    joined = assemble(static, [*others, *with_details])
    plain = assemble(static, [*others, *tcr1])

    def tcr1_sigma(result: SessionParameters) -> float:
        return next(p.sigma for p in result.periods if p.key == "TcR1")

    assert tcr1_sigma(joined) > 1.5 * tcr1_sigma(plain)  # the shared systematic is not averaged down
    session = SessionAssembly(static)
    session.add_all(others)
    if details_first:
        assert not any(session.add_details(d) for d in details)  # nothing held yet to join
        session.add_all(tcr1)
    else:
        session.add_all(tcr1)
        assert all(session.add_details(d) for d in details)
    assert {t.trial_id: t for t in session.trials} == {t.trial_id: t for t in (*others, *with_details)}
    assert_same_set(session.result().parameters, joined.parameters)
    assert tcr1_sigma(session.result()) == tcr1_sigma(joined)


def test_later_details_and_estimates_keep_the_join() -> None:
    """Re-published details replace the earlier; a re-published estimate keeps its trial's details."""
    full = load_measurements(bicycle("browser"))
    session = SessionAssembly(load_static_readings(bicycle("browser")))
    trial = _tcr1_trials(full)[0]
    first, second = _shared_systematic([trial], 1e-4)[0], _shared_systematic([trial], 3e-4)[0]
    assert session.add(trial) and session.add_details(first)
    assert not session.add_details(first)  # the same details again change nothing
    assert session.add_details(second)
    assert session.trials == (second.apply(trial),)
    again = TrialFit.from_period(trial.trial_id, "TcR1", trial.period + 2e-6, trial.period_sigma, True)
    assert session.add(again)
    assert session.trials == (second.apply(again),)
    assert session.trials[0].fit.small_swing_systematic == 3e-4


def test_a_refused_estimate_is_joined_alike() -> None:
    """The details of an estimate the assembly refuses stay, and :meth:`joined` gives it them as ``add`` would."""
    session = SessionAssembly(load_static_readings(bicycle("browser")))
    rogue = TrialFit.from_period("rogue-t1", "TtQ7", 1.2, 1e-4, True)
    details = dataclasses.replace(FitDetails.of(rogue), ends_period=1.21, ends_period_sigma=1e-3)
    assert not session.add_details(details)
    with pytest.raises(AssemblyError, match="not a period"):
        session.add(rogue)
    assert session.trials == ()
    assert session.joined(rogue) == details.apply(rogue)
    assert session.joined(rogue).fit.ends_period == 1.21
    other = TrialFit.from_period("other-t1", "TcR1", 1.36, 1e-4, True)
    assert session.joined(other) is other  # no details: as is
