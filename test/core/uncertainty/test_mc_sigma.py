"""The printed σ: Monte Carlo where it departs from the linear σ or lines are nearly parallel."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from bike_rig.core.benchmark import compute_parameters, monte_carlo_parameters
from bike_rig.core.loader import load_measurements
from bike_rig.core.measurements import Measurements
from bike_rig.core.uncertainty.mc_sigma import (
    MC_DEPARTURE,
    MC_SAMPLES,
    MC_SEED,
    NEAR_PARALLEL_DEG,
    line_angles,
    printed_sigmas,
)

DATA = Path("/work/shared/data/bicycleparameters")


def _measurements(name: str) -> Measurements:
    path = DATA / name / "RawData" / f"{name}Measured.txt"
    if not path.exists():
        pytest.skip(f"{path} not available")
    return load_measurements(path)


def test_rigid_frame_mass_centre_gets_the_monte_carlo_sigma() -> None:
    m = _measurements("Rigid")
    lin = compute_parameters(m).parameters
    got = printed_sigmas(m, lin)
    assert got.near_parallel["B"] < NEAR_PARALLEL_DEG
    assert {"xB", "zB"} <= got.monte_carlo
    draws = monte_carlo_parameters(
        dataclasses.replace(m, readings=dict(sorted(m.readings.items()))), MC_SAMPLES, MC_SEED
    )
    for name in ("xB", "zB"):
        assert got.sigma[name] == pytest.approx(float(np.std(draws[name], ddof=1)), rel=1e-12)
        assert got.linear[name] == pytest.approx(lin.sigma(name), rel=1e-12)
        assert got.sigma[name] != pytest.approx(lin.sigma(name), rel=1e-3)
    for name in set(lin.names) - got.monte_carlo:
        assert got.sigma[name] == lin.sigma(name)
    note = got.note()
    assert note is not None and "20,000-draw Monte Carlo" in note and "frame 1.2°" in note
    assert printed_sigmas(m, lin).sigma == got.sigma  # seeded: the same σ again
    shuffled = dataclasses.replace(m, readings=dict(reversed(list(m.readings.items()))))
    assert printed_sigmas(shuffled, lin).sigma == got.sigma  # the file's reading order does not matter


def test_well_spread_lines_keep_the_linear_sigma() -> None:
    m = _measurements("Browser")
    lin = compute_parameters(m).parameters
    got = printed_sigmas(m, lin)
    assert min(line_angles(m).values()) >= NEAR_PARALLEL_DEG
    assert not got.monte_carlo and got.note() is None
    assert got.sigma == {n: lin.sigma(n) for n in lin.names}


def test_lines_made_nearly_parallel_switch_to_the_monte_carlo_sigma() -> None:
    m = _measurements("Browser")
    r = dict(m.readings)
    r["alphaB2"] = dataclasses.replace(r["alphaB2"], value=r["alphaB1"].value + 3.0)
    near = dataclasses.replace(m, readings=r)
    lin = compute_parameters(near).parameters
    got = printed_sigmas(near, lin)
    assert got.near_parallel["B"] == pytest.approx(3.0)
    assert {"xB", "zB"} <= got.monte_carlo and not {"xH", "zH"} & got.monte_carlo
    for name in got.monte_carlo - {"xB", "zB"}:
        assert abs(got.sigma[name] / lin.sigma(name) - 1.0) > MC_DEPARTURE, name
    for name in set(lin.names) - got.monte_carlo:
        assert got.sigma[name] == lin.sigma(name)


def test_large_angle_sigma_on_spread_lines_switches_to_the_monte_carlo_sigma() -> None:
    """Lines 41–45° apart, but angles read to ±4°: the formulas bend over the σ, no angle rule sees it."""
    m = _measurements("Browser")
    wide = {k: dataclasses.replace(r, sigma=4.0) if k.startswith("alpha") else r for k, r in m.readings.items()}
    rough = dataclasses.replace(m, readings=wide)
    assert min(line_angles(rough).values()) >= NEAR_PARALLEL_DEG
    lin = compute_parameters(rough).parameters
    got = printed_sigmas(rough, lin)
    assert "IByy" in got.monte_carlo and not got.near_parallel
    for name in got.monte_carlo:
        assert abs(got.sigma[name] / lin.sigma(name) - 1.0) > MC_DEPARTURE, name
    for name in set(lin.names) - got.monte_carlo:
        assert got.sigma[name] == lin.sigma(name)
    note = got.note()
    assert note is not None and "departs from it by more than 2 %" in note
