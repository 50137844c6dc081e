"""Surface-plate readings of 0, a stray frame distance, a byte-order mark: read as BicycleParameters reads them.

``data/zero_readings`` holds BicycleParameters' own ``GyroMeasured.txt`` (h4 = h5 = d3 = d4 = 0 ± 0,
an ``aB4`` with no angle and no period) and ``Balanceassistv1Measured.txt`` (h2 = 0, d2 = d3 = 0 ± 5 mm),
and two Rigid-derived files written the same ways (``Zerooffset``, ``Zeroaxle``). Beside each, the
``<Name>Benchmark.txt`` BicycleParameters 1.5.2 computes from it, written by
``bench/bench_zero_readings.py --write`` (which ``make bench`` re-checks live). All BSD-2-Clause,
(c) 2011-2025 BicycleParameters Authors.

Values agree to 1e-9 relative (in fact ≤ 3e-13). σ agree to 1e-3 once our formulas are propagated
under BicycleParameters' λ convention (λ an independent input with the σ of atan(c_s/(a + b)), see
``test_against_bicycleparameters.py``); our own σ are confirmed by Monte Carlo, BicycleParameters'
are up to 52 % too large (x_H of Balanceassistv1).
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bike_rig.core import surface_plate
from bike_rig.core.benchmark import (
    PARAMETER_NAMES,
    ParameterSet,
    benchmark_formulas,
    compute_parameters,
    part_output_names,
)
from bike_rig.core.errors import InputFileError, MeasurementError
from bike_rig.core.io_bp import read_bp_measured, read_bp_parameters
from bike_rig.core.loader import load_input
from bike_rig.core.measurements import Measurements, SurfacePlateError, validate
from bike_rig.core.uncertainty.uncertain import UncertainVector, complex_step_jacobian, monte_carlo
from test.support.paper import shared_dir

DATA = Path(__file__).parent / "data" / "zero_readings"
NAMES = ("Balanceassistv1", "Gyro", "Zeroaxle", "Zerooffset")
RIGID = shared_dir() / "data" / "bicycleparameters" / "Rigid" / "RawData" / "RigidMeasured.txt"


def _raw(name: str) -> Path:
    return DATA / f"{name}Measured.txt"


def _vectors(ps: ParameterSet) -> list[UncertainVector]:
    return [ps.parameters] + ([ps.parts] if ps.parts is not None else [])


def _offsets(m: Measurements) -> tuple[float, float, float]:
    """(a, b, c_s) of a surface-plate file, m."""
    v = {k: r.value for k, r in m.readings.items()}
    a = surface_plate.rear_frame_offset(v["h1"], v["h2"], v["h3"], v["d1"], v["d2"])
    b = surface_plate.fork_offset(v["h4"], v["h5"], v["d3"], v["d4"])
    return a, b, float(surface_plate.steer_axis_distance(a, b, v["d"], v["d2"], v["d3"]))


def _bp_lambda_convention(m: Measurements, monkeypatch: pytest.MonkeyPatch) -> UncertainVector:
    """Our formulas with λ an independent input of σ = σ(atan(c_s/(a + b))), as BicycleParameters 1.5.2 has it."""
    values = {k: r.value for k, r in m.readings.items()}
    perturbed = [k for k, r in m.readings.items() if r.sigma > 0]
    var = [m.readings[k].sigma ** 2 for k in perturbed]

    def guess(x: Any) -> dict[str, Any]:
        a = surface_plate.rear_frame_offset(x["h1"], x["h2"], x["h3"], x["d1"], x["d2"])
        b = surface_plate.fork_offset(x["h4"], x["h5"], x["d3"], x["d4"])
        return {"guess": np.arctan(surface_plate.steer_axis_distance(a, b, x["d"], x["d2"], x["d3"]) / (a + b))}

    sigma_guess = float(np.sqrt(complex_step_jacobian(guess, values, perturbed).covariance(np.diag(var))[0, 0]))
    lam = compute_parameters(m).parameters.value("lam")
    held: dict[str, Any] = {}
    monkeypatch.setattr(surface_plate, "steer_axis_tilt_from_offsets", lambda *_: held["lam"])

    def evaluate(x: Any) -> Any:
        held["lam"] = x["lam_independent"]
        return benchmark_formulas(x)

    names = PARAMETER_NAMES + part_output_names(m.readings)
    prop = complex_step_jacobian(evaluate, {**values, "lam_independent": lam}, [*perturbed, "lam_independent"], names)
    return prop.with_covariance(np.diag([*var, sigma_guess**2]))


@pytest.mark.parametrize("name", NAMES)
def test_values_equal_bicycleparameters_to_1e_9(name: str) -> None:
    ours = compute_parameters(read_bp_measured(_raw(name)))
    ref = read_bp_parameters(DATA / f"{name}Benchmark.txt")
    assert (ours.parts is None) == (ref.parts is None)
    assert ours.parameters.names == ref.parameters.names == PARAMETER_NAMES
    for mine, theirs in zip(_vectors(ours), _vectors(ref)):
        assert mine.names == theirs.names
        for key in theirs.names:
            assert mine.value(key) == pytest.approx(theirs.value(key), rel=1e-9, abs=0), key


@pytest.mark.parametrize("name", NAMES)
def test_sigma_equal_bicycleparameters_under_its_lambda_convention(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    m = read_bp_measured(_raw(name))
    ref = read_bp_parameters(DATA / f"{name}Benchmark.txt")
    theirs_convention = _bp_lambda_convention(m, monkeypatch)
    for theirs in _vectors(ref):
        for key in theirs.names:
            assert theirs_convention.sigma(key) == pytest.approx(theirs.sigma(key), rel=1e-3, abs=1e-15), key


#: Where our σ and BicycleParameters' differ by more than 0.1 %: (bicycle, key, BP's σ / Monte Carlo's at least).
DIFFERENCES = [
    ("Balanceassistv1", "xH", 1.4),
    ("Balanceassistv1", "c", 1.03),
    ("Balanceassistv1", "w", None),
    ("Gyro", "w", None),
    ("Gyro", "xH", None),
    ("Zeroaxle", "xH", 1.2),
    ("Zeroaxle", "c", None),
    ("Zeroaxle", "w", None),
    ("Zerooffset", "w", None),
    ("Zerooffset", "xH", None),
]


@pytest.mark.parametrize(("name", "key", "bp_too_large"), DIFFERENCES)
def test_our_sigma_is_the_monte_carlo_one(name: str, key: str, bp_too_large: float | None) -> None:
    """20 000 draws of the readings through the same formulas: our linear σ within 4 %; BicycleParameters' not."""
    m = read_bp_measured(_raw(name))
    values = {k: r.value for k, r in m.readings.items()}
    perturbed = [k for k, r in m.readings.items() if r.sigma > 0]
    cov = np.diag([m.readings[k].sigma ** 2 for k in perturbed])
    draws = monte_carlo(benchmark_formulas, values, cov, perturbed, 20000, 17, [key])
    sigma_mc = float(np.std(draws[key]))
    assert compute_parameters(m).parameters.sigma(key) == pytest.approx(sigma_mc, rel=0.04)
    theirs = read_bp_parameters(DATA / f"{name}Benchmark.txt").parameters.sigma(key)
    if bp_too_large is not None:
        assert theirs > bp_too_large * sigma_mc


def test_zero_diameters_mean_readings_to_the_axle_centres() -> None:
    """Zeroaxle is Rigid read to its axle centres (d2 = d3 = 0, h2 = 0): the same bicycle, within a twentieth of σ."""
    zero, rigid = read_bp_measured(_raw("Zeroaxle")), read_bp_measured(RIGID)
    assert np.allclose(_offsets(zero), _offsets(rigid), rtol=0, atol=5e-5)
    ours, theirs = compute_parameters(zero).parameters, compute_parameters(rigid).parameters
    for key in PARAMETER_NAMES:
        assert abs(ours.value(key) - theirs.value(key)) <= 0.05 * ours.sigma(key) + 1e-15, key


def test_zero_heights_of_the_fork_mean_no_fork_offset() -> None:
    """h4 = h5 = d3 = d4 = 0 ± 0: b = 0 exactly, so the trail is r_F tan λ (Eq 8 with f_o = 0)."""
    m = read_bp_measured(_raw("Zerooffset"))
    assert _offsets(m)[1] == 0.0
    p = compute_parameters(m).parameters
    assert p.value("c") == pytest.approx(p.value("rF") * np.tan(p.value("lam")), rel=1e-14)


@pytest.mark.parametrize("name", ["Gyro", "Zerooffset"])
def test_a_frame_distance_without_angle_or_period_is_set_aside(name: str, caplog: pytest.LogCaptureFixture) -> None:
    """``aB4`` beside three frame orientations places no line: kept as an other entry, noted, as BicycleParameters."""
    path = _raw(name)
    line = next(n for n, text in enumerate(path.read_text().splitlines(), 1) if text.startswith("aB4 "))
    with caplog.at_level(logging.WARNING, logger="bike_rig.core.io_bp"):
        m = read_bp_measured(path)
    assert "aB4" not in m.readings and m.extras["aB4"] == path.read_text().splitlines()[line - 1].split("= ")[1]
    assert m.orientations("B") == [1, 2, 3]
    assert [r.getMessage() for r in caplog.records] == [
        f"{path}:{line}: key 'aB4': set aside: this hanging has no angle (alphaB4) and no torsional period "
        "(TtB4), so it places no line and no inertia; kept with the file's other entries (BicycleParameters "
        "ignores it too)"
    ]


def test_a_period_without_its_hanging_angle_is_still_refused(tmp_path: Path) -> None:
    """A swung orientation with no angle is a lost measurement, not a stray distance: named, not dropped."""
    path = tmp_path / "HalfMeasured.txt"
    path.write_text(_raw("Zerooffset").read_text() + "TtB4 = 2.5+/-0.0001\n")
    m = read_bp_measured(path)
    with pytest.raises(MeasurementError, match="frame orientation 4 lacks this reading") as info:
        validate(m)
    assert info.value.key == "alphaB4"


def _with(tmp_path: Path, name: str, **values: str) -> Path:
    """A copy of ``name``'s raw file with some readings replaced."""
    lines = []
    for text in _raw(name).read_text().splitlines():
        key = text.split("=")[0].strip()
        lines.append(f"{key} = {values.pop(key)}" if key in values else text)
    assert not values, values
    path = tmp_path / f"{name}Measured.txt"
    path.write_text("\n".join(lines) + "\n")
    return path


def _line(path: Path, key: str) -> int:
    return next(n for n, text in enumerate(path.read_text().splitlines(), 1) if text.split("=")[0].strip() == key)


@pytest.mark.parametrize(
    ("name", "values", "key", "reason"),
    [
        ("Zerooffset", {"d3": "0.01+/-0.00004"}, "h4", "the dummy front axle would sink into the surface plate"),
        ("Zeroaxle", {"h3": "0.02+/-0.00008"}, "h3", "the head tube would sink into the surface plate"),
        ("Zeroaxle", {"h1": "0.001+/-0.00008", "d2": "0.01+/-0.00004"}, "h1", "the dummy rear axle would sink"),
        ("Zeroaxle", {"d": "0.9+/-0.00008"}, "d", "no steer-axis distance c_s closes that triangle"),
        ("Zeroaxle", {"h1": "0.02+/-0.00008", "h3": "0.2+/-0.00008", "d": "0.5+/-0.00008"}, "h1", r"\(a \+ b > 0\)"),
        ("Zeroaxle", {"l": "0.02+/-0.002"}, "l", "the handlebar reference centre is"),
        ("Zeroaxle", {"h7": "0.01+/-0.00001"}, "h7", "the handlebar reference circle would sink"),
    ],
)
def test_impossible_plate_geometry_is_refused_naming_file_line_and_key(
    tmp_path: Path, name: str, values: dict[str, str], key: str, reason: str
) -> None:
    path = _with(tmp_path, name, **values)
    with pytest.raises(SurfacePlateError, match=reason) as info:
        compute_parameters(read_bp_measured(path))
    assert (info.value.path, info.value.key, info.value.line) == (str(path), key, _line(path, key))
    assert "\n" not in str(info.value) and str(info.value).startswith(f"{path}:{_line(path, key)}: key '{key}': ")


def test_a_tube_resting_on_the_plate_is_not_refused_for_its_reading_errors(tmp_path: Path) -> None:
    """Top = diameter means the tube lies on the plate; a reading 2σ below that is still possible."""
    path = _with(tmp_path, "Zeroaxle", h5="0.02843+/-0.00008", d4="0.02855+/-0.00004")
    compute_parameters(read_bp_measured(path))


@pytest.mark.parametrize("key", ["h2", "d2", "d", "l"])
def test_a_negative_plate_reading_is_refused(tmp_path: Path, key: str) -> None:
    path = _with(tmp_path, "Zeroaxle", **{key: "-0.001+/-0.00001"})
    with pytest.raises(MeasurementError, match="a surface-plate height, diameter or distance cannot be negative"):
        validate(read_bp_measured(path))


@pytest.mark.parametrize("kind", ["Measured", "Benchmark"])
def test_a_byte_order_mark_is_read_as_such(tmp_path: Path, kind: str) -> None:
    """A file saved with a UTF-8 BOM: its first key is its first key (``lF`` was reported missing)."""
    src = _raw("Gyro") if kind == "Measured" else DATA / "GyroBenchmark.txt"
    body = "\n".join(t for t in src.read_text().splitlines() if not t.startswith("#")) + "\n"
    plain, marked = tmp_path / f"Plain{kind}.txt", tmp_path / f"Marked{kind}.txt"
    plain.write_text(body)
    marked.write_bytes(body.encode("utf-8-sig"))
    a, b = load_input(plain), load_input(marked)
    assert type(a) is type(b)
    if isinstance(a, Measurements) and isinstance(b, Measurements):
        assert {k: (r.value, r.sigma, r.origin and r.origin.line) for k, r in a.readings.items()} == {
            k: (r.value, r.sigma, r.origin and r.origin.line) for k, r in b.readings.items()
        }
        assert b.readings[body.split(" ")[0]].origin is not None
    else:
        assert isinstance(a, ParameterSet) and isinstance(b, ParameterSet)
        assert a.values() == b.values()


def test_a_key_given_twice_is_refused_naming_both_lines(tmp_path: Path) -> None:
    text = _raw("Zeroaxle").read_text()
    path = tmp_path / "TwiceMeasured.txt"
    path.write_text(text + "d2 = 0.0098+/-0.00004\n")
    first, second = _line(path, "d2"), len(path.read_text().splitlines())
    with pytest.raises(InputFileError) as info:
        read_bp_measured(path)
    assert str(info.value) == f"{path}:{second}: key 'd2': given twice (first on line {first})"
