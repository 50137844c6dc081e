"""Reading and writing measurement and parameter files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from bike_rig.config.paths import config_dir
from bike_rig.core.benchmark import PARAMETER_NAMES, benchmark_formulas, compute_parameters
from bike_rig.core.errors import MeasurementError
from bike_rig.core.io_bp import BP_SPEED_M_S, dump_bp_parameter_yaml, parse_value, read_bp_measured
from bike_rig.core.io_yaml import dump_measurements_yaml
from bike_rig.core.loader import load_input, load_measurements
from bike_rig.core.measurements import Measurements, Reading
from test.support.paper import BICYCLE_NAMES, shared_dir

BIKES = sorted(BICYCLE_NAMES.values())


def _raw(bike: str) -> Path:
    return shared_dir() / "data" / "bicycleparameters" / bike / "RawData" / f"{bike}Measured.txt"


def test_parse_value_forms() -> None:
    assert parse_value("0.1+/-0.01") == (0.1, 0.01)
    assert parse_value(" 9.81 +/- 0.01 ") == (9.81, 0.01)
    assert parse_value("2 ± 0.5") == (2.0, 0.5)
    assert parse_value("13") == (13.0, 0.0)
    v, s = parse_value("0.1+/-0.03, 0.2+/-0.04")  # BicycleParameters averages, σ of the mean
    assert v == pytest.approx(0.15) and s == pytest.approx(0.025)
    with pytest.raises(ValueError, match="could not convert"):
        parse_value("abc")


@pytest.mark.parametrize("bike", BIKES)
def test_shipped_yaml_equals_the_raw_file(bike: str) -> None:
    """config/bicycles/<bike>.yaml holds exactly the readings of <Bike>Measured.txt."""
    ours = load_measurements(config_dir() / "bicycles" / f"{bike.lower()}.yaml")
    raw = read_bp_measured(_raw(bike))
    assert ours.bicycle == bike
    assert {k: (r.value, r.sigma) for k, r in ours.readings.items()} == {
        k: (r.value, r.sigma) for k, r in raw.readings.items()
    }
    assert {k: str(v) for k, v in ours.extras.items()} == {k: str(v) for k, v in raw.extras.items()}


def test_yaml_round_trip_is_bit_identical(tmp_path: Path) -> None:
    raw = read_bp_measured(_raw("Stratos"))
    path = tmp_path / "stratos.yaml"
    path.write_text(dump_measurements_yaml(raw))
    back = load_measurements(path)
    a = compute_parameters(raw).parameters
    b = compute_parameters(back).parameters
    assert list(a.values) == list(b.values)


def test_yaml_accepts_mapping_and_string_values(tmp_path: Path) -> None:
    text = (config_dir() / "bicycles" / "browser.yaml").read_text()
    text = text.replace("gravity: [9.81, 0.01]", "gravity: {value: 9.81, sigma: 0.01}")
    text = text.replace("wheelbase: [1.121, 0.002]", "wheelbase: '1.121 +/- 0.002'")
    path = tmp_path / "b.yaml"
    path.write_text(text)
    m = load_measurements(path)
    assert (m.readings["g"].value, m.readings["g"].sigma) == (9.81, 0.01)
    assert (m.readings["w"].value, m.readings["w"].sigma) == (1.121, 0.002)


def test_more_than_three_orientations_are_used(tmp_path: Path) -> None:
    """A fourth hanging orientation enters both the mass centre and the inertia tensor."""
    m = read_bp_measured(_raw("Browser"))
    p3 = compute_parameters(m).parameters
    out = benchmark_formulas({k: r.value for k, r in m.readings.items()})
    # a fourth orientation at 80° consistent with the three-orientation result (Eq 10, 14, 34)
    alpha4 = 80.0
    beta = out["lam"] - np.deg2rad(alpha4)
    slope = -np.tan(beta)
    a4 = -(out["zB"] - slope * out["xB"] + out["rR"]) * np.cos(beta)
    s, c = np.sin(beta), np.cos(beta)
    J4 = c * c * out["IBxx"] - 2 * s * c * out["IBxz"] + s * s * out["IBzz"]
    T4 = 2 * np.pi * np.sqrt(J4 / out["k"])
    readings = dict(m.readings)
    for key, value, sigma in (("alphaB4", alpha4, 0.2), ("aB4", a4, 0.003), ("TtB4", T4, 2e-5)):
        readings[key] = Reading(float(value), sigma)
    four = Measurements("Browser4", readings, m.path)
    p4 = compute_parameters(four).parameters
    # the extra line and the extra moment add information: σ shrink
    for name in ("xB", "zB", "IBxx", "IBzz"):
        assert p4.sigma(name) < p3.sigma(name), name
    assert p4.value("xB") == pytest.approx(p3.value("xB"), abs=3 * p3.sigma("xB"))


def test_bp_parameter_yaml_is_readable_back(tmp_path: Path) -> None:
    ps = compute_parameters(read_bp_measured(_raw("Fisher")))
    path = tmp_path / "fisher_bp.yml"
    path.write_text(dump_bp_parameter_yaml(ps))
    doc = yaml.safe_load(path.read_text())
    assert doc["parameterization"] == "Meijaard2007"
    assert set(doc["values"]) == {*PARAMETER_NAMES, "v"}  # Meijaard2007ParameterSet requires the speed
    assert doc["values"]["v"] == BP_SPEED_M_S
    assert doc["rider"] is False
    assert all(isinstance(v, float) for v in doc["values"].values())
    back = load_input(path)
    assert not isinstance(back, Measurements)
    assert back.values() == ps.values()


def test_bp_parameter_yaml_says_rider_and_speed() -> None:
    ps = compute_parameters(read_bp_measured(_raw("Fisher")))
    doc = yaml.safe_load(dump_bp_parameter_yaml(ps, rider=True, speed=3.0))
    assert doc["rider"] is True
    assert doc["values"]["v"] == 3.0


def test_parameter_files_are_recognised() -> None:
    bench = load_input(config_dir() / "bicycles" / "benchmark.yaml")
    assert not isinstance(bench, Measurements)
    assert bench.values()["IBxz"] == 2.4
    txt = load_input(shared_dir() / "data/bicycleparameters/Browser/Parameters/BrowserBenchmark.txt")
    assert not isinstance(txt, Measurements)
    assert txt.parameters.sigma("IBxx") == pytest.approx(0.00247550148476)


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        ("mass: [9.86, 0.02]", "mass: [1.0e+308, 0.02]", r"value 1e\+308 is beyond any plausible reading"),
        ("mass: [9.86, 0.02]", "mass: [9.86, 1.0e+308]", r"sigma 1e\+308 is beyond any plausible reading"),
        ("mass: [9.86, 0.02]", "mass: [9.86, -0.02]", "sigma must be >= 0, got -0.02"),
        ("mass: [9.86, 0.02]", "mass: [.inf, 0.02]", "value and sigma must be finite numbers"),
        ("mass: [9.86, 0.02]", 'mass: "9.86 +/- -0.02"', "sigma must be >= 0"),
    ],
)
def test_absurd_readings_are_refused_at_the_reader(tmp_path: Path, old: str, new: str, match: str) -> None:
    """Readings near 1e308 overflowed in the propagation; a negative σ was accepted."""
    text = (config_dir() / "bicycles" / "browser.yaml").read_text()
    assert old in text
    path = tmp_path / "bad.yaml"
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(MeasurementError, match=match) as info:
        load_input(path)
    assert info.value.key == "frame.mass" and info.value.line is not None


@pytest.mark.parametrize(
    ("entry", "match"),
    [("1e308+/-0.1", "beyond any plausible reading"), ("0.5+/--0.1", "sigma must be >= 0, got -0.1")],
)
def test_absurd_parameters_are_refused(tmp_path: Path, entry: str, match: str) -> None:
    """A parameter file (ours or BicycleParameters' Benchmark.txt) with an absurd value or a negative σ."""
    lines = [f"{k} = 1.0+/-0.1" for k in PARAMETER_NAMES]
    lines[PARAMETER_NAMES.index("rR")] = f"rR = {entry}"
    path = tmp_path / "BadBenchmark.txt"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(MeasurementError, match=match) as info:
        load_input(path)
    assert info.value.key == "rR"
    ours = tmp_path / "bad.yaml"
    value, _, sigma = entry.partition("+/-")
    body = "".join(f"  {k}: [{value if k == 'rR' else 1.0}, {sigma if k == 'rR' else 0.1}]\n" for k in PARAMETER_NAMES)
    ours.write_text(f"format: bike_rig-parameters/1\nbicycle: b\nparameters:\n{body}")
    with pytest.raises(MeasurementError, match=match):
        load_input(ours)


def test_absurd_readings_in_measured_txt_are_refused(tmp_path: Path) -> None:
    text = _raw("Browser").read_text()
    path = tmp_path / "BrowserMeasured.txt"
    path.write_text(text.replace("mB = ", "mB = 1e300*", 1).replace("1e300*", "1e300 +/- 0.1 #", 1))
    with pytest.raises(MeasurementError, match="beyond any plausible reading") as info:
        load_input(path)
    assert info.value.key == "mB"
