"""Our parameters from the raw files equal BicycleParameters' own computed ``*Benchmark.txt``.

The ``*Benchmark.txt`` files were computed by BicycleParameters from the same ``*Measured.txt``
files (BSD-2-Clause, (c) 2011-2025 BicycleParameters Authors). Values agree to 1e-6 relative
(they actually agree to ~1e-11: the files print 12 significant digits) and σ to 1 %.
"""

from __future__ import annotations

import pytest

from bike_rig.core.benchmark import PARAMETER_NAMES, compute_parameters
from bike_rig.core.io_bp import read_bp_measured, read_bp_parameters
from test.support.paper import BICYCLE_NAMES, shared_dir

BIKES = sorted(BICYCLE_NAMES.values())


def _data(bike: str, kind: str) -> str:
    folder = "RawData" if kind == "Measured" else "Parameters"
    return str(shared_dir() / "data" / "bicycleparameters" / bike / folder / f"{bike}{kind}.txt")


@pytest.mark.parametrize("bike", BIKES)
def test_parameters_equal_bicycleparameters(bike: str) -> None:
    ours = compute_parameters(read_bp_measured(_data(bike, "Measured"))).parameters
    ref = read_bp_parameters(_data(bike, "Benchmark")).parameters
    for name in PARAMETER_NAMES:
        assert ours.value(name) == pytest.approx(ref.value(name), rel=1e-6, abs=0), name
        assert ours.sigma(name) == pytest.approx(ref.sigma(name), rel=0.01, abs=1e-15), name


def test_six_bicycles_are_covered() -> None:
    assert BIKES == ["Browser", "Browserins", "Crescendo", "Fisher", "Stratos", "Yellow"]
