"""Simulated sessions for the bag tests (simulated once per run)."""

from __future__ import annotations

import pytest

from bike_rig.core.sim import SimulatedSession
from test.support.simulated import short_session


@pytest.fixture(scope="session")
def session() -> SimulatedSession:
    """A whole simulated Browser session with 12 s trials."""
    return short_session()
