"""How a weave or capsize speed with σ is written: one function, the same text everywhere (issue 11)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from bike_rig.cli.model_cmd import speeds_text
from bike_rig.config.paths import config_dir
from bike_rig.console.app import title_text
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.loader import load_measurements
from bike_rig.core.textfmt import format_speed, format_value_sigma
from bike_rig.core.uncertainty.speed_sigma import SpeedWithSigma, critical_speeds_with_sigma
from bike_rig.pipeline.model import compute_model

BICYCLES = config_dir() / "bicycles"


@pytest.mark.parametrize(("speed", "sigma"), [(4.19531, 0.04512), (4.19531, 0.0045), (4.19531, 0.0996), (12.3, 1.27)])
def test_a_speed_and_its_sigma_are_written_by_the_one_rule(speed: float, sigma: float) -> None:
    value, sig = format_value_sigma(speed, sigma, digits=None)
    assert format_speed(SpeedWithSigma(speed, sigma)) == f"{value} ± {sig} m/s"
    assert format_speed(SpeedWithSigma(speed, sigma), compact=True) == f"{value}±{sig}"
    decimals = len(sig.partition(".")[2])
    assert len(value.partition(".")[2]) == decimals  # the same place
    assert float(sig) == pytest.approx(sigma, rel=0.12) and float(value) == pytest.approx(speed, abs=sigma)


@pytest.mark.parametrize(
    ("sigma", "expected"),
    [
        (0.01234, "0.012"),  # leading 123: two digits
        (0.03549, "0.035"),  # 354: still two
        (0.03551, "0.04"),  # 355: one
        (0.0949, "0.09"),  # 949: one
        (0.0951, "0.10"),  # 951: up to the next decade, two digits
        (0.999, "1.0"),
        (1.27, "1.3"),
        (460.0, "500"),
        (2.5e-7, "0.00000025"),
    ],
)
def test_sigma_digits_follow_the_particle_data_group_rule(sigma: float, expected: str) -> None:
    assert format_value_sigma(1.0, sigma, digits=None)[1] == expected


@pytest.mark.parametrize("value", [-0.0, -1e-9, -0.0004])
def test_a_value_that_rounds_to_zero_has_no_sign(value: float) -> None:
    assert not format_value_sigma(value, 0.01, digits=None)[0].startswith("-")
    assert not format_value_sigma(value, 0.01)[0].startswith("-")


def test_the_eigenvalue_table_writes_no_negative_zero_nor_a_vanishing_imaginary_part() -> None:
    from bike_rig.cli.format import eigen_cell

    assert eigen_cell(complex(-0.0, -1e-12)).split() == ["0.000000"]
    assert eigen_cell(complex(-3.5, 4e-8)).split() == ["-3.500000"]
    assert eigen_cell(complex(-1e-9, 2.0)).split() == ["0.000000", "+2.000000j"]
    assert eigen_cell(complex(1.5, -2.25)).split() == ["1.500000", "-2.250000j"]
    assert len({len(eigen_cell(z)) for z in (complex(0, 0), complex(-1, 2), complex(1, -2))}) == 1


def test_a_speed_without_a_usable_sigma_or_without_a_crossing_says_why() -> None:
    exact, undefined = SpeedWithSigma(4.2923831, 0.0), SpeedWithSigma(4.2923831, math.nan)
    assert format_speed(exact) == "4.292383 ± 0 m/s (the parameters carry no σ)"
    assert format_speed(undefined) == "4.292383 m/s (σ undefined: not a simple root)"
    assert format_speed(None, "capsize") == "none (no capsize crossing)"
    assert format_speed(SpeedWithSigma(math.nan, math.nan)) == "none"
    assert format_speed(exact, compact=True) == "4.29238±0"
    assert format_speed(undefined, compact=True) == "4.29238"
    assert format_speed(None, "weave", compact=True) == "none"


def test_the_console_title_and_model_write_the_speeds_alike() -> None:
    """The console's title and ``bike-rig model`` (the demo's lines: ``test/cli/test_demo_cmd.py``).

    A σ below 0.01 m/s needs a fourth decimal: the console's title wrote every speed to three
    decimals before (``4.195±0.002``), ``model`` to the σ's second digit (``4.1953 ± 0.0025``).
    """
    ps = compute_parameters(load_measurements(BICYCLES / "browser.yaml"))
    _, sweep = compute_model(ps, [0.0])
    assert sweep.weave is not None and sweep.capsize is not None
    title = title_text("Browser", 68, 68, sweep)
    weave, capsize = format_speed(sweep.weave, compact=True), format_speed(sweep.capsize, compact=True)
    assert title == f"bike_rig · Browser · 68/68 done  weave {weave}  capsize {capsize} m/s"
    assert len(title) <= 80
    assert title_text("Browser", 3, 68, None) == "bike_rig · Browser · 3/68 done"
    cs = critical_speeds_with_sigma(ps)
    text = speeds_text(cs)
    assert f"weave speed:   {format_speed(cs.weave, 'weave')}\n" in text
    assert f"capsize speed: {format_speed(cs.capsize, 'capsize')}\n" in text
    small = SpeedWithSigma(sweep.weave.speed, 0.0025)
    assert f"weave {format_speed(small, compact=True)} " in title_text("Browser", 68, 68, replace(sweep, weave=small))
    assert format_speed(small, compact=True).endswith("±0.0025")
