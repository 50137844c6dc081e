"""Impossible parameters refused at every reader and producer, traced to their readings; unit mistakes named."""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import pytest

from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import ParameterSet
from bike_rig.core.inertia import compound_pendulum_inertia
from bike_rig.core.loader import load_input, load_static_readings
from bike_rig.core.measurements import Measurements
from bike_rig.core.parameter_checks import compound_period_min, compute_checked
from bike_rig.core.plausibility import ImplausibleParametersError
from bike_rig.core.reading_ranges import (
    PARAMETER_RANGES,
    READING_RANGES,
    UnitMistakeWarning,
    parameter_unit_mistakes,
    unit_mistakes,
)
from bike_rig.core.rider import RiderError, load_rider
from test.support.paper import real_files, shared_dir

BENCHMARK = config_file("bicycles/benchmark.yaml")


def browser_measured() -> str:
    return (shared_dir() / "data" / "bicycleparameters" / "Browser" / "RawData" / "BrowserMeasured.txt").read_text()


def measured(tmp_path: Path, key: str, text: str) -> Path:
    """Browser's Measured.txt with one reading replaced (``key = text``)."""
    src = browser_measured()
    out, n = re.subn(rf"^{key} = .*$", f"{key} = {text}", src, flags=re.M)
    assert n == 1
    path = tmp_path / f"{key}Measured.txt"
    path.write_text(out)
    return path


def parameter_file(tmp_path: Path, key: str, value: float) -> Path:
    """The benchmark bicycle's parameter file with one value replaced."""
    out, n = re.subn(rf"^  {key}: \[.*\]$", f"  {key}: [{value!r}, 0.0]", BENCHMARK.read_text(), flags=re.M)
    assert n == 1
    path = tmp_path / f"p_{key}.yaml"
    path.write_text(out)
    return path


def load_quietly(path: Path) -> Measurements | ParameterSet:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnitMistakeWarning)
        return load_input(path)


def test_a_compound_period_too_short_for_its_arm_names_both_and_the_shortest_period(tmp_path: Path) -> None:
    m = load_input(measured(tmp_path, "TcR1", "0.1+/-0.001"))
    assert isinstance(m, Measurements)
    with pytest.raises(ImplausibleParametersError) as err:
        compute_checked(m)
    need = 2 * math.pi * math.sqrt(0.29325 / 9.81)
    text = str(err.value)
    assert "\n" not in text
    assert "TcR1 = 0.1 s with lR = 0.29325 m gives IRyy = -0.26" in text
    assert f"a compound period of at least {need:.4g} s is needed" in text


def test_the_shortest_compound_period_gives_a_zero_moment() -> None:
    for length, g in ((0.29325, 9.81), (0.05, 9.78), (1.3, 9.83)):
        t = compound_period_min(length, g)
        assert abs(compound_pendulum_inertia(3.0, g, length, t)) < 1e-12
        assert (
            compound_pendulum_inertia(3.0, g, length, t * 1.01)
            > 0
            > compound_pendulum_inertia(3.0, g, length, t * 0.99)
        )


def test_a_frame_torsional_period_of_200_s_is_refused_naming_that_reading(tmp_path: Path) -> None:
    m = load_input(measured(tmp_path, "TtB1", "200+/-0.001"))
    assert isinstance(m, Measurements)
    with pytest.raises(ImplausibleParametersError) as err:
        compute_checked(m)
    text = str(err.value)
    assert text.startswith(f"{m.path}: bicycle '{m.bicycle}' is not physically possible: TtB1 = 200 s")
    assert "IBzz" in text or "IBxx" in text


def test_the_real_raw_files_compute_unchanged() -> None:
    for path in sorted((shared_dir() / "data" / "bicycleparameters").glob("*/RawData/*Measured.txt")):
        m = load_input(path)
        assert isinstance(m, Measurements)
        assert compute_checked(m).values() is not None


@pytest.mark.parametrize(
    ("key", "value", "words"),
    [
        ("w", 0.0, "w = 0 m: the wheelbase must be positive"),
        ("rR", 0.0, "rR = 0 m: a wheel radius must be positive"),
        ("lam", math.pi / 2, "lam = 1.5708 rad: the steer-axis tilt must lie within"),
        ("lam", 7.0, "lam = 7 rad: the steer-axis tilt must lie within"),
        ("g", -9.81, "g = -9.81 m/s²: gravity must be positive"),
        ("mB", 0.0, "mB = 0 kg: the rear frame's mass must be positive"),
        ("IBxx", -9.2, "IBxx = -9.2 kg m²: an inertia must be positive"),
        ("IBxz", 9.0, "IBxz² < IBxx·IBzz"),
        ("IRyy", 0.13, "IRyy ≤ 2·IRxx"),
        ("zB", 0.2, "zB = 0.2 m: the rear frame's mass centre must be above the ground"),
    ],
)
def test_an_impossible_parameter_file_is_refused_naming_the_key(
    tmp_path: Path, key: str, value: float, words: str
) -> None:
    path = parameter_file(tmp_path, key, value)
    with pytest.raises(ImplausibleParametersError) as err:
        load_quietly(path)
    assert str(err.value).startswith(f"{path}: parameter set 'Benchmark' is not physically possible: ")
    assert words in str(err.value)


def test_a_tilt_in_degrees_is_named_as_such_in_the_refusal(tmp_path: Path) -> None:
    with pytest.raises(ImplausibleParametersError, match=r"lam looks like degrees"):
        load_quietly(parameter_file(tmp_path, "lam", 18.0))
    with pytest.raises(ImplausibleParametersError) as err:  # π/2 is no tilt in degrees either
        load_quietly(parameter_file(tmp_path, "lam", math.pi / 2))
    assert "looks like" not in str(err.value)


@pytest.mark.parametrize(
    ("key", "text", "expected"),
    [
        (
            "w",
            "1121+/-2",
            "w = 1121 m is outside the plausible wheelbase (0.5 to 2.5 m): it looks like millimetres (w = 1.121 m)",
        ),
        (
            "mF",
            "2020+/-20",
            "mF = 2020 kg is outside the plausible front wheel mass (0.5 to 10 kg): it looks like grams (mF = 2.02 kg)",
        ),
        (
            "gamma",
            "1.171+/-0.0035",
            "gamma = 1.171 deg is outside the plausible head-tube angle (45 to 85 deg): "
            "it looks like radians (gamma = 67.0934 deg)",
        ),
    ],
)
def test_a_reading_in_a_wrong_unit_warns_with_the_file_line_unit_and_corrected_value(
    tmp_path: Path, key: str, text: str, expected: str
) -> None:
    path = measured(tmp_path, key, text)
    line = next(i for i, s in enumerate(path.read_text().splitlines(), 1) if s.startswith(f"{key} = "))
    for reader in (load_input, load_static_readings):
        with pytest.warns(UnitMistakeWarning) as caught:
            reader(path)
        assert [str(w.message) for w in caught] == [f"{path}:{line}: {expected}"]


def test_a_wrong_unit_is_an_error_when_warnings_of_its_class_are(tmp_path: Path) -> None:
    path = measured(tmp_path, "w", "1121+/-2")
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnitMistakeWarning)
        with pytest.raises(UnitMistakeWarning, match="looks like millimetres"):
            load_input(path)


def test_a_parameter_in_a_wrong_unit_warns(tmp_path: Path) -> None:
    path = parameter_file(tmp_path, "w", 1020.0)
    with pytest.warns(UnitMistakeWarning, match=r"key 'w': w = 1020 m .* millimetres \(w = 1.02 m\)"):
        load_input(path)


def test_no_real_file_has_a_value_outside_its_range() -> None:
    files = list(real_files())
    assert len(files) > 20
    for path in files:
        with warnings.catch_warnings():
            warnings.simplefilter("error", UnitMistakeWarning)
            got = load_input(path)
        if isinstance(got, Measurements):
            values = {k: r.value for k, r in got.readings.items()}
            assert [k for k in values if k in READING_RANGES and not READING_RANGES[k].holds(values[k])] == [], path
            assert unit_mistakes(values) == []
        else:
            assert parameter_unit_mistakes(got.values()) == [], path
            bad = [k for k, r in PARAMETER_RANGES.items() if not r.holds(got.values()[k])]
            assert bad == [], (path, bad)


def test_a_value_no_unit_explains_is_no_unit_mistake() -> None:
    assert unit_mistakes({"w": 0.3, "mF": 60.0, "gamma": 30.0, "TcR1": 1e6}) == []
    assert [u.likely for u in unit_mistakes({"w": 102.0})] == [("centimetres",)]


def rider_file(tmp_path: Path, **changes: float) -> Path:
    values = {"mass": 72.0, "x": 0.3, "z": -1.2, "Ixx": 7.0, "Iyy": 8.0, "Izz": 2.0, "Ixz": 1.0, **changes}
    path = tmp_path / "rider.yaml"
    path.write_text("".join(f"{k}: {v!r}\n" for k, v in values.items()))
    return path


def test_a_possible_rider_file_reads(tmp_path: Path) -> None:
    assert load_rider(rider_file(tmp_path)).mass == 72.0


@pytest.mark.parametrize(
    ("changes", "words"),
    [
        ({"Iyy": 15.0}, "break the triangle inequality"),
        ({"Ixz": 4.0}, "not positive definite"),
        ({"Izz": -2.0}, "Izz = -2 kg m²: an inertia must be positive"),
        ({"z": 0.3}, "z = 0.3 m: the rider's mass centre must be above the ground"),
    ],
)
def test_an_impossible_rider_file_is_refused(tmp_path: Path, changes: dict[str, float], words: str) -> None:
    path = rider_file(tmp_path, **changes)
    with pytest.raises(RiderError) as err:
        load_rider(path)
    assert str(err.value).startswith(f"{path}: not physically possible: ")
    assert words in str(err.value)
