"""core/budget: every output's variance split over the raw readings (or parameters).

Checked: the shares of every output sum to 1 and reproduce the linear σ of the parameters and
critical speeds; they match shares built from central differences of ``compute_parameters``
and ``critical_speeds`` (no complex step, no implicit function theorem); riders, parameter files
and correlated inputs (grouped) are handled as documented in the module.
"""

from __future__ import annotations

import dataclasses
import json
import math
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import ParameterSet, RawPropagation, compute_parameters
from bike_rig.core.io_yaml import dump_parameters_yaml
from bike_rig.core.loader import load_input, load_measurements
from bike_rig.core.measurements import Measurements
from bike_rig.core.rider import PAPER_RIDER, add_rider, combine_rear_frame
from bike_rig.core.symbols import PARAMETER_NAMES
from bike_rig.core.uncertainty.budget import (
    BUDGET_PARAMETERS,
    CAPSIZE,
    OUTPUT_UNITS,
    WEAVE,
    BudgetError,
    UncertaintyBudget,
    budget_json,
    input_ranking,
    reading_names,
    uncertainty_budget,
)
from bike_rig.core.uncertainty.speed_sigma import critical_speeds_with_sigma
from bike_rig.core.whipple import canonical_matrices, critical_speeds
from test.support.paper import shared_dir

BICYCLES = ("browser", "browserins", "crescendo", "fisher", "stratos", "yellow")
#: Rear-frame parameters that a rider makes correlated in a parameter file's covariance.
REAR_FRAME_GROUP = "IBxx+IBxz+IByy+IBzz+mB+xB+zB"


@cache
def measurements(name: str) -> Measurements:
    return load_measurements(config_file(f"bicycles/{name}.yaml"))


@cache
def parameters(name: str) -> ParameterSet:
    return compute_parameters(measurements(name))


def parameter_file_set(tmp_path: Path, name: str = "browser") -> ParameterSet:
    """The bicycle's parameters round-tripped through a parameter file (σ, no raw readings)."""
    path = tmp_path / f"{name}-parameters.yaml"
    path.write_text(dump_parameters_yaml(parameters(name)), encoding="utf-8")
    got = load_input(path)
    assert isinstance(got, ParameterSet) and got.raw is None
    return got


def check_consistent(b: UncertaintyBudget, ps: ParameterSet) -> None:
    """Shares sum to 1, are positive and sorted; σ equals the linear σ of the parameter set."""
    speeds = critical_speeds_with_sigma(ps)
    expected = list(BUDGET_PARAMETERS) + [n for n, s in ((WEAVE, speeds.weave), (CAPSIZE, speeds.capsize)) if s]
    assert [o.output for o in b.outputs] == expected
    for o in b.outputs:
        assert o.unit == OUTPUT_UNITS[o.output]
        if o.output in BUDGET_PARAMETERS:
            assert o.value == ps.parameters.value(o.output)
            assert o.sigma == pytest.approx(ps.parameters.sigma(o.output), rel=1e-9, abs=1e-300)
        else:
            sp = speeds.weave if o.output == WEAVE else speeds.capsize
            assert sp is not None
            assert o.value == sp.speed
            assert o.sigma == pytest.approx(sp.sigma, rel=1e-9)
        if o.sigma == 0.0:
            assert o.shares == ()
            continue
        shares = np.array([s.share for s in o.shares])
        assert math.fsum(shares) == pytest.approx(1.0, abs=1e-12), o.output
        assert np.all(shares > 0.0) and np.all(np.diff(shares) <= 0.0)
        contributions = np.array([s.contribution for s in o.shares])
        assert math.sqrt(math.fsum(contributions**2)) == pytest.approx(o.sigma, rel=1e-12)
        assert {s.input for s in o.shares} <= set(b.inputs)


@pytest.mark.parametrize("name", BICYCLES)
def test_shares_sum_to_one_for_every_bicycle(name: str) -> None:
    ps = parameters(name)
    b = uncertainty_budget(ps)
    assert b.input_kind == "raw readings"
    assert ps.raw is not None and b.inputs == ps.raw.names
    assert b.output(WEAVE) and b.output(CAPSIZE)  # the six bicycles have both speeds
    check_consistent(b, ps)


def test_benchmark_parameter_file_has_no_shares() -> None:
    """The benchmark file gives every σ as 0: each output has σ 0 and nothing to share."""
    ps = load_input(config_file("bicycles/benchmark.yaml"))
    assert isinstance(ps, ParameterSet)
    b = uncertainty_budget(ps)
    assert b.input_kind == "parameters" and b.inputs == PARAMETER_NAMES
    check_consistent(b, ps)
    assert all(o.sigma == 0.0 and o.shares == () for o in b.outputs)
    assert input_ranking(b) == ()


def test_parameter_file_budget_is_over_the_parameters(tmp_path: Path) -> None:
    """Independent parameters: each parameter is its own budget; the speeds split over them."""
    ps = parameter_file_set(tmp_path)
    b = uncertainty_budget(ps)
    assert b.input_kind == "parameters" and b.inputs == PARAMETER_NAMES
    check_consistent(b, ps)
    for name in BUDGET_PARAMETERS:
        o = b.output(name)
        if o.sigma > 0:
            assert [(s.input, s.share) for s in o.shares] == [(name, 1.0)]
    weave = critical_speeds_with_sigma(ps).weave
    assert weave is not None and weave.gradient is not None
    for s in b.output(WEAVE).shares:
        k = PARAMETER_NAMES.index(s.input)
        assert s.contribution == pytest.approx(abs(weave.gradient[k]) * ps.parameters.sigma(s.input), rel=1e-12)


def test_parameter_file_with_rider_groups_the_correlated_rear_frame(tmp_path: Path) -> None:
    """A rider correlates mB, xB, zB, IB** of a parameter file: they form one budget input."""
    ps = add_rider(parameter_file_set(tmp_path), PAPER_RIDER)
    b = uncertainty_budget(ps)
    assert REAR_FRAME_GROUP in b.inputs
    assert len(b.inputs) == len(PARAMETER_NAMES) - 6  # seven parameters became one input
    check_consistent(b, ps)
    assert [s.input for s in b.output("xB").shares] == [REAR_FRAME_GROUP]
    # The group's share is its block's variance s_G Σ_GG s_Gᵀ over the total.
    weave = critical_speeds_with_sigma(ps).weave
    assert weave is not None and weave.gradient is not None
    idx = [PARAMETER_NAMES.index(n) for n in REAR_FRAME_GROUP.split("+")]
    grad, cov = weave.gradient[idx], ps.parameters.covariance[np.ix_(idx, idx)]
    share = next(s for s in b.output(WEAVE).shares if s.input == REAR_FRAME_GROUP)
    assert share.share == pytest.approx(float(grad @ cov @ grad) / weave.sigma**2, rel=1e-9)


def test_correlated_raw_readings_are_grouped() -> None:
    """A raw covariance with a cross term links two readings; every other reading stays alone."""
    ps = parameters("browser")
    assert ps.raw is not None
    names = ps.raw.names
    i, j = names.index("aH2"), names.index("aH3")
    cov = ps.raw.covariance.copy()
    cov[i, j] = cov[j, i] = 0.8 * math.sqrt(cov[i, i] * cov[j, j])
    jac = ps.raw.jacobian
    params = dataclasses.replace(ps.parameters, covariance=jac @ cov @ jac.T)
    correlated = dataclasses.replace(ps, parameters=params, raw=RawPropagation(names, cov, jac))
    b = uncertainty_budget(correlated)
    assert "aH2+aH3" in b.inputs and "aH2" not in b.inputs and len(b.inputs) == len(names) - 1
    check_consistent(b, correlated)
    row = jac[PARAMETER_NAMES.index("xH"), [i, j]]
    pair = next(s for s in b.output("xH").shares if s.input == "aH2+aH3")
    assert pair.contribution == pytest.approx(math.sqrt(row @ cov[np.ix_([i, j], [i, j])] @ row), rel=1e-12)


def test_budget_with_the_rider() -> None:
    """The rider is exact: the same raw readings, new sensitivities for the rear frame and speeds."""
    ps = parameters("browser")
    bare, ridden = uncertainty_budget(ps), uncertainty_budget(add_rider(ps, PAPER_RIDER))
    assert ridden.bicycle == f"{ps.bicycle} + {PAPER_RIDER.name}"
    assert ridden.inputs == bare.inputs
    check_consistent(ridden, add_rider(ps, PAPER_RIDER))
    # mB + 72 kg: the same σ and the same shares.
    assert ridden.output("mB").sigma == pytest.approx(bare.output("mB").sigma, rel=1e-12)
    assert [s.input for s in ridden.output("mB").shares] == [s.input for s in bare.output("mB").shares]
    # Front-assembly parameters do not see the rider at all.
    assert ridden.output("IHxx") == bare.output("IHxx")
    # The speeds do change (the rider moves them by about a metre per second).
    assert abs(ridden.output(WEAVE).value - bare.output(WEAVE).value) > 0.1


def perturbed(m: Measurements, key: str, step: float) -> Measurements:
    r = m.readings[key]
    return dataclasses.replace(m, readings={**m.readings, key: dataclasses.replace(r, value=r.value + step)})


def outputs_of(values: dict[str, float]) -> np.ndarray:
    """The 25 parameters and both speeds (NaN if absent), from plain float parameters."""
    cs = critical_speeds(canonical_matrices(values), values["g"])
    speeds = [math.nan if v is None else v for v in (cs.weave, cs.capsize)]
    return np.array([values[n] for n in BUDGET_PARAMETERS] + speeds)


#: Central-difference step, as a fraction of each reading's σ. Truncation error of the
#: derivative is O((h/L)²) with L the scale over which the output curves (≫ σ, as the linear
#: and Monte Carlo σ agree within 2 %), so ≤ 1e-4 relative here; round-off is about
#: ε |y| / h, below 1e-9 of the largest contribution for every output (σ_y/|y| ≥ 1e-5).
FD_STEP = 1e-2
#: Agreement demanded of shares (absolute) and of the contributions that carry at least 0.1 %
#: of the variance (relative). Measured over the six bicycles with and without the rider: at
#: most 3e-8 and 8e-8, so the margin is over 30× and 100×.
FD_SHARE_TOL = 1e-6
FD_CONTRIBUTION_RTOL = 1e-5


@pytest.mark.parametrize("rider", [False, True])
@pytest.mark.parametrize("name", BICYCLES)
def test_shares_match_central_differences(name: str, rider: bool) -> None:
    m = measurements(name)
    ps = compute_parameters(m)
    if rider:
        ps = add_rider(ps, PAPER_RIDER)
    b = uncertainty_budget(ps)
    assert ps.raw is not None

    def outputs(mm: Measurements) -> np.ndarray:
        values = compute_parameters(mm).parameters.as_dict()
        return outputs_of(combine_rear_frame(values, PAPER_RIDER) if rider else values)

    sigmas = np.sqrt(np.diag(ps.raw.covariance))
    columns = []
    for key, sigma in zip(ps.raw.names, sigmas):
        h = FD_STEP * sigma
        columns.append((outputs(perturbed(m, key, h)) - outputs(perturbed(m, key, -h))) / (2 * h) * sigma)
    contrib = np.abs(np.array(columns).T)  # (outputs, readings): |∂y/∂x_j| σ_j
    names = list(BUDGET_PARAMETERS) + [WEAVE, CAPSIZE]
    for row, out in zip(contrib, names):
        o = b.output(out)
        fd_share = row**2 / np.sum(row**2)
        got = {s.input: s for s in o.shares}
        for key, fs, fc in zip(ps.raw.names, fd_share, row):
            s = got.get(key)
            assert (s.share if s else 0.0) == pytest.approx(fs, abs=FD_SHARE_TOL), (out, key)
            if fs >= 1e-3:
                assert s is not None and s.contribution == pytest.approx(fc, rel=FD_CONTRIBUTION_RTOL), (out, key)


def test_output_lookup_and_top() -> None:
    b = uncertainty_budget(parameters("fisher"))
    weave = b.output(WEAVE)
    assert b.top(WEAVE, 3) == weave.shares[:3] and len(b.top(WEAVE, 3)) == 3
    assert b.top(WEAVE) == weave.shares[:5]
    with pytest.raises(BudgetError, match="no output 'nope'"):
        b.output("nope")
    with pytest.raises(BudgetError):
        b.output("g")  # g is an input, not a budget output


def test_input_ranking_is_the_mean_share() -> None:
    b = uncertainty_budget(parameters("browser"))
    ranked = input_ranking(b)
    means = [r.mean_share for r in ranked]
    assert math.fsum(means) == pytest.approx(1.0, abs=1e-12)  # every output's shares sum to 1
    assert means == sorted(means, reverse=True)
    # Recompute one entry by hand: the top input's mean share over all 27 outputs.
    top = ranked[0].input
    by_hand = sum(next((s.share for s in o.shares if s.input == top), 0.0) for o in b.outputs) / len(b.outputs)
    assert ranked[0].mean_share == pytest.approx(by_hand, rel=1e-12)
    leaders = [o.output for o in b.outputs if o.shares[0].input == top]
    assert ranked[0].leads == tuple(leaders)
    speeds = input_ranking(b, [WEAVE, CAPSIZE])
    assert speeds[0].input in {b.output(WEAVE).shares[0].input, b.output(CAPSIZE).shares[0].input}


def test_budget_json_is_plain_json() -> None:
    b = uncertainty_budget(parameters("stratos"))
    data = json.loads(json.dumps(budget_json(b), allow_nan=False))
    assert set(data) == {"bicycle", "input_kind", "inputs", "input_keys", "outputs"}
    assert data["inputs"] == list(b.inputs)
    assert [o["output"] for o in data["outputs"]] == [o.output for o in b.outputs]
    first = data["outputs"][-1]
    assert set(first) == {"output", "value", "sigma", "unit", "shares", "systematic"} and first["systematic"] == []
    assert first["shares"][0] == {
        "input": b.outputs[-1].shares[0].input,
        "key": b.outputs[-1].shares[0].key,
        "share": b.outputs[-1].shares[0].share,
        "contribution": b.outputs[-1].shares[0].contribution,
    }


def test_inputs_are_named_as_their_file_names_them() -> None:
    """``names`` renames inputs (groups too); shares, contributions and keys stay the same."""
    m = load_measurements(config_file("bicycles/browser.yaml"))
    names = reading_names(m)
    assert names["aH3"] == "fork.orientations[2].distance" and names["TtP1"] == "calibration_rod.torsional_period"
    ps = compute_parameters(m)
    plain, named = uncertainty_budget(ps), uncertainty_budget(ps, names)
    assert named.input_keys == plain.inputs == plain.input_keys
    assert named.inputs == tuple(names[k] for k in plain.inputs)
    for a, b in zip(plain.outputs, named.outputs):
        assert [(s.input, s.share, s.contribution) for s in a.shares] == [
            (s.key, s.share, s.contribution) for s in b.shares
        ]
    assert ps.raw is not None
    i, j = ps.raw.names.index("aH2"), ps.raw.names.index("aH3")
    cov = ps.raw.covariance.copy()
    cov[i, j] = cov[j, i] = 0.5 * math.sqrt(cov[i, i] * cov[j, j])
    correlated = dataclasses.replace(ps, raw=RawPropagation(ps.raw.names, cov, ps.raw.jacobian))
    grouped = uncertainty_budget(correlated, names)
    k = grouped.input_keys.index("aH2+aH3")
    assert grouped.inputs[k] == "fork.orientations[1].distance+fork.orientations[2].distance"
    bp = load_measurements(shared_dir() / "data" / "bicycleparameters" / "Browser" / "RawData" / "BrowserMeasured.txt")
    assert all(k == v for k, v in reading_names(bp).items())
