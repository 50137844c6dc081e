"""Conditioning of the mass-centre lines."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bike_rig.core.com import line_conditioning


def test_perpendicular_lines_are_well_conditioned() -> None:
    cond = line_conditioning([1.0, -1.0])
    assert cond.min_angle == pytest.approx(math.pi / 2)
    assert cond.condition_number == pytest.approx(1.0)


def test_nearly_parallel_lines_are_flagged_by_angle_and_condition() -> None:
    a = math.radians(30.0)
    well = line_conditioning([math.tan(a), math.tan(a + math.radians(50.0))])
    poor = line_conditioning([math.tan(a), math.tan(a + math.radians(1.2))])
    assert poor.min_angle == pytest.approx(math.radians(1.2), rel=1e-9)
    assert poor.condition_number > 10.0 * well.condition_number


def test_smallest_pair_wins_among_three_lines() -> None:
    slopes = np.tan(np.radians([10.0, 13.9, 80.0]))
    assert line_conditioning(list(slopes)).min_angle == pytest.approx(math.radians(3.9))


def test_angle_wraps_across_vertical() -> None:
    slopes = np.tan(np.radians([89.5, -89.5]))
    assert line_conditioning(list(slopes)).min_angle == pytest.approx(math.radians(1.0))


def test_parallel_lines_give_infinite_condition() -> None:
    cond = line_conditioning([0.5, 0.5])
    assert cond.min_angle == 0.0
    assert math.isinf(cond.condition_number) or cond.condition_number > 1e12


def test_single_line_refused() -> None:
    with pytest.raises(ValueError, match="at least two lines"):
        line_conditioning([0.3])
