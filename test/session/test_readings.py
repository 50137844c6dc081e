"""A typed static reading: parsing, the hard checks, and the plausibility warnings."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.loader import load_measurements
from bike_rig.core.measurements import Measurements, Reading
from bike_rig.pipeline.readings import ReadingEntry, is_static_key
from bike_rig.session.readings import (
    ImpossibleValueError,
    NotANumberError,
    NotInPlanError,
    ReadingInputError,
    SigmaError,
    UnknownKeyError,
    parse_reading,
    plausibility,
    plausible_range,
    reading_unit,
)

SHIPPED = ("browser", "browserins", "crescendo", "fisher", "stratos", "yellow")


def _measured_files(shared_dir: Path) -> list[Path]:
    return sorted((shared_dir / "data" / "bicycleparameters").glob("*/RawData/*Measured.txt"))


@pytest.fixture(scope="module")
def browser() -> dict[str, Reading]:
    return dict(load_measurements(config_file("bicycles/browser.yaml")).readings)


def _static(m: Measurements) -> dict[str, Reading]:
    return {k: r for k, r in m.readings.items() if is_static_key(k)}


# ------------------------------------------------------------------------------ real bicycles


def test_no_real_reading_of_any_bicycle_warns_and_every_one_parses(shared_dir: Path) -> None:
    """The nine bicycles of ../shared/data (Rigid too: its masses, rolls and hangings) and the shipped YAML files.

    Each reading is checked against the whole bicycle (every cross-check can fire) and, in
    file order, against the readings before it.
    """
    files = _measured_files(shared_dir)
    assert len(files) == 9
    sets = [load_measurements(f) for f in files]
    sets += [load_measurements(config_file(f"bicycles/{b}.yaml")) for b in SHIPPED]
    checked = 0
    for m in sets:
        static = _static(m)
        assert len(static) >= 13, m.path
        before: dict[str, Reading] = {}
        for key, r in static.items():
            sigma = "" if key in ("nR", "nF") else repr(r.sigma)
            entry = parse_reading(key, repr(r.value), sigma)
            assert (entry.value, entry.sigma) == (r.value, r.sigma)
            assert plausibility(key, r.value, r.sigma, static) == [], (m.path, key)
            assert plausibility(key, r.value, r.sigma, before) == [], (m.path, key)
            before[key] = r
            checked += 1
    assert checked > 300


# ------------------------------------------------------------------------------ parsing


def test_a_reading_parses_to_an_entry_in_the_keys_unit() -> None:
    e = parse_reading(" gamma ", "67.1", "0.2", stamp_ns=5, note="first")
    assert e == ReadingEntry("gamma", 67.1, 0.2, 5, "first")
    assert parse_reading("nF", "13") == ReadingEntry("nF", 13.0, 0.0)
    assert parse_reading("aB3", -0.294, 0.003).value == -0.294
    assert parse_reading("mF", "2.02", None, default_sigma=0.02).sigma == 0.02
    assert parse_reading("alphaB4", "10", "0.2", allowed=["alphaB4"]).key == "alphaB4"
    assert [reading_unit(k) for k in ("gamma", "alphaH2", "nR", "g", "mB", "aH1", "dP")] == [
        "deg",
        "deg",
        "1",
        "m/s^2",
        "kg",
        "m",
        "m",
    ]


@pytest.mark.parametrize(
    ("key", "value", "sigma", "error", "words"),
    [
        ("TtB1", "2.1", "1e-4", UnknownKeyError, "periods come from trials"),
        ("wheelbase", "1.1", "0.002", UnknownKeyError, "unknown key 'wheelbase'"),
        ("alphaB0", "10", "0.2", UnknownKeyError, "unknown key"),
        ("mF", "2,02", "0.02", NotANumberError, "'2,02' is not a number"),
        ("mF", "nan", "0.02", NotANumberError, "finite"),
        ("mF", "2.02", "inf", NotANumberError, "finite"),
        ("mF", "2.02", "0", SigmaError, "σ 0 would make the reading exact"),
        ("mF", "2.02", None, SigmaError, "σ missing"),
        ("mF", "2.02", "-0.02", SigmaError, "σ must be >= 0"),
        ("nF", "13", "1", SigmaError, "exact count"),
        ("nF", "12.5", None, ImpossibleValueError, "whole count"),
        ("mF", "-2.02", "0.02", ImpossibleValueError, "must be positive"),
        ("gamma", "95", "0.2", ImpossibleValueError, "(0, 90]"),
        ("alphaH1", "400", "0.2", ImpossibleValueError, "[-360, 360]"),
        ("alphaB4", "10", "0.2", NotInPlanError, "not a reading of this session's plan"),
    ],
)
def test_a_bad_reading_is_refused_in_one_line_naming_where_key_and_why(
    key: str, value: str, sigma: str | None, error: type[ReadingInputError], words: str
) -> None:
    allowed = ["alphaB1", "alphaB2", "alphaB3"] if key == "alphaB4" else None
    with pytest.raises(error) as caught:
        parse_reading(key, value, sigma, where="stdin:7", allowed=allowed)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"stdin:7: key '{key}': ")
    assert words in message
    assert caught.value.key == key


def test_the_hard_checks_are_the_measurement_files(browser: dict[str, Reading]) -> None:
    """What parse_reading refuses as impossible, a measurement file refuses too, and what it takes, the file takes."""
    from bike_rig.core.errors import MeasurementError
    from bike_rig.core.measurements import validate

    def file_accepts(key: str, value: float, sigma: float) -> bool:
        readings = dict(browser)
        readings[key] = Reading(value, sigma)
        try:
            validate(Measurements("Browser", readings))
        except MeasurementError:
            return False
        return True

    cases = [
        ("gamma", 90.0, 0.2),
        ("gamma", 90.5, 0.2),
        ("alphaB1", -360.0, 0.2),
        ("alphaB1", -361.0, 0.2),
        ("w", 1e-9, 0.002),
        ("w", 0.0, 0.002),
        ("nR", 13.0, 0.0),
        ("nR", 13.2, 0.0),
        ("aB1", -0.5, 0.003),
    ]
    for key, value, sigma in cases:
        try:
            parse_reading(key, repr(value), repr(sigma) if sigma else None)
            parsed = True
        except ImpossibleValueError:
            parsed = False
        assert parsed == file_accepts(key, value, sigma), (key, value)


# ------------------------------------------------------------------------------ plausibility


def _one(warnings: list[str], *words: str) -> None:
    assert len(warnings) >= 1
    hits = [w for w in warnings if all(x in w for x in words)]
    assert hits, warnings
    assert all("\n" not in w for w in warnings)


@pytest.mark.parametrize(
    ("key", "value", "sigma", "words"),
    [
        ("gamma", 1.171, 0.0035, ("gamma = 1.171", "looks like radians", "67.09")),
        ("gamma", 22.9, 0.2, ("gamma = 22.9", "steer-axis tilt", "67.1")),
        ("w", 1121.0, 2.0, ("w = 1121", "millimetres", "1.121 m")),
        ("w", 112.1, 0.2, ("w = 112.1", "centimetres")),
        ("w", 44.0, 0.1, ("w = 44", "inches")),
        ("f", 70.5, 1.0, ("f = 70.5", "millimetres", "0.0705 m")),
        ("mF", 2020.0, 20.0, ("mF = 2020", "grams", "front wheel mass")),
        ("mB", 50.0, 0.1, ("mB = 50", "pounds", "frame mass")),
        ("mF", 12.0, 0.02, ("mF = 12", "front wheel mass", "0.5 to 10 kg")),
        ("mB", 1.5, 0.02, ("mB = 1.5", "frame mass", "2 to 40 kg")),
        ("mH", 11.0, 0.02, ("mH = 11", "fork")),
        ("mP", 25.0, 0.02, ("mP = 25", "calibration rod mass")),
        ("g", 32.2, 0.03, ("g = 32.2", "ft/s²")),
        ("aH1", 474.0, 3.0, ("aH1 = 474", "millimetres")),
        ("dP", 30.0, 0.1, ("dP = 30", "millimetres")),
        ("lF", 293.0, 1.0, ("lF = 293", "millimetres")),
        ("mR", 3.11, 5.0, ("mR = 3.11 ± 5", "σ is larger than the value")),
        ("alphaB1", -10.0, 0.2, ("alphaB1 = -10", "0 to 360", "350°")),
        ("alphaH3", 367.0, 0.2, ("alphaH3 = 367", "7°")),
    ],
)
def test_each_likely_mistake_is_named(
    browser: dict[str, Reading], key: str, value: float, sigma: float, words: tuple[str, ...]
) -> None:
    _one(plausibility(key, value, sigma, browser), *words)
    real = browser[key]
    assert plausibility(key, real.value, real.sigma, browser) == []


def test_a_trail_in_metres_names_the_fork_offset_or_the_angle(browser: dict[str, Reading]) -> None:
    """The trail is Eq 8 by the core: with the offset in mm it comes out as tens of metres."""
    _one(plausibility("f", 70.5, 1.0, browser), "trail", "c = -76.", "fork offset f = 70.5", "millimetres")
    _one(plausibility("f", 7.05, 0.1, browser), "trail", "millimetres (= 0.00705 m) or centimetres (= 0.0705 m)")
    _one(plausibility("gamma", 1.171, 0.0035, browser), "trail", "c = 13.", "head-tube angle gamma = 1.171")
    # the trail needs the front wheel's radius, the angle and the offset: nothing to say without them
    early = {k: browser[k] for k in ("g", "w")}
    assert not [w for w in plausibility("f", 70.5, 1.0, early) if "trail" in w]
    # an offset and an angle each plausible on their own, whose trail is not
    slack = dict(browser)
    slack["gamma"] = Reading(45.0, 0.2)
    _one(plausibility("f", -0.14, 0.001, slack), "trail", "c = 0.54", "check the fork offset f and")


def test_a_rolled_distance_inconsistent_with_the_rotations(browser: dict[str, Reading]) -> None:
    _one(plausibility("dF", 28060.0, 10.0, browser), "dF = 28060", "wheel radius", "looks like millimetres")
    _one(plausibility("dF", 2.158, 0.01, browser), "dF = 2.158", "one rotation, not of nF = 13")
    _one(plausibility("nR", 1.0, 0.0, browser), "nR = 1", "wheel radius dR / (2π nR) = 4.4", "rotations nR = 1 right")
    _one(plausibility("dR", 0.3, 0.01, browser), "dR = 0.3", "is dR in metres")
    # one mistake, one warning: the arm, trail and wheelbase checks wait for a plausible radius
    assert len(plausibility("dF", 28060.0, 10.0, browser)) == 1
    # before the rotations are known the distance is judged on its own
    alone = {k: browser[k] for k in ("g", "w")}
    _one(plausibility("dR", 27850.0, 10.0, alone), "dR = 27850", "millimetres")


def test_a_pendulum_arm_longer_than_the_wheel_radius(browser: dict[str, Reading]) -> None:
    _one(plausibility("lF", 0.5, 0.001, browser), "lF = 0.5", "longer than the wheel radius", "0.3435")
    # the same found when the rolling comes after the arm
    readings = dict(browser)
    readings["lR"] = Reading(0.45, 0.001)
    _one(plausibility("dR", browser["dR"].value, 0.01, readings), "dR = 27.85", "pendulum arm lR = 0.45")


def test_a_wheelbase_shorter_than_the_wheels(browser: dict[str, Reading]) -> None:
    _one(plausibility("w", 0.6, 0.002, browser), "w = 0.6", "shorter than the two wheel radii", "(0.68")


def test_warnings_take_plain_values_and_a_new_value_replaces_the_old(browser: dict[str, Reading]) -> None:
    plain = {k: r.value for k, r in browser.items()}
    assert plausibility("gamma", 1.171, 0.0035, plain) == plausibility("gamma", 1.171, 0.0035, browser)
    entries = {k: ReadingEntry(k, r.value, r.sigma) for k, r in browser.items()}
    assert plausibility("f", 70.5, 1.0, entries) == plausibility("f", 70.5, 1.0, browser)
    wrong = dict(browser)
    wrong["f"] = Reading(70.5, 1.0)  # the correction of a wrong offset does not warn
    assert plausibility("f", 0.0705, 0.001, wrong) == []


def test_every_static_key_has_a_range_and_others_none() -> None:
    for key in ("g", "w", "gamma", "f", "mR", "nR", "dR", "lR", "mF", "mB", "mH", "mP", "lP", "dP", "alphaB7", "aH2"):
        rng = plausible_range(key)
        assert rng is not None and rng.low < rng.high and math.isfinite(rng.high)
    assert plausible_range("TtB1") is None and plausible_range("lcs") is None
