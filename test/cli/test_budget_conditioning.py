"""The budget's hanging-line conditioning and Monte Carlo check."""

from __future__ import annotations

from pathlib import Path

import pytest

from bike_rig.cli.budget_cmd import conditioning_lines
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.loader import load_measurements

DATA = Path("/work/shared/data/bicycleparameters")


def _lines(name: str) -> list[str]:
    path = DATA / name / "RawData" / f"{name}Measured.txt"
    if not path.exists():
        pytest.skip(f"{path} not available")
    m = load_measurements(path)
    return conditioning_lines(m, compute_parameters(m).parameters)


def test_rigid_frame_lines_flagged_and_checked_by_monte_carlo() -> None:
    lines = _lines("Rigid")
    frame = next(x for x in lines if x.strip().startswith("frame"))
    assert "nearly parallel" in frame
    assert any(x.startswith("Monte Carlo check") for x in lines)


def test_well_spread_lines_skip_the_monte_carlo_check() -> None:
    lines = _lines("Browser")
    assert not any("nearly parallel" in x for x in lines)
    assert not any(x.startswith("Monte Carlo check") for x in lines)
