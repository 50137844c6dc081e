"""Fixtures of the simulator's tests: the shipped rig and true bicycles."""

from __future__ import annotations

import os
import secrets

import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.sim.rig import RigConfig, load_rig
from test.support.paper import table2


@pytest.fixture(scope="session")
def rig() -> RigConfig:
    """The shipped rig, ``config/rig.yaml``."""
    return load_rig(config_file("rig.yaml"))


@pytest.fixture(scope="session")
def browser_truth() -> dict[str, float]:
    """The paper's Table 2 column B (Browser) as true parameters, with g = 9.81 m/s²."""
    params = {key: cell.value for key, cell in table2()["B"].items()}
    params["g"] = 9.81
    return params


@pytest.fixture
def seed() -> int:
    """A fresh seed per test, printed so that a failure can be repeated with ``BIKE_RIG_TEST_SEED``.

    Any seed must pass: the statistical tests state their failure probability.
    """
    fixed = os.environ.get("BIKE_RIG_TEST_SEED")
    value = int(fixed) if fixed else secrets.randbelow(2**32)
    print(f"seed = {value} (BIKE_RIG_TEST_SEED={value} repeats this run)")
    return value
