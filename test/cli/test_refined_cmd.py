"""``bike-rig params`` and the YAML formats on raw files of the refined method.

The refined method (Moore's dissertation) measures the geometry on a surface plate and hangs the
fork S and handlebar G separately; the per-part outputs are reported beside the 26 parameters,
checked against BicycleParameters' own ``*Benchmark.txt`` (BSD-2-Clause, (c) 2011-2025
BicycleParameters Authors). Every directory under ``../shared/data/bicycleparameters`` whose raw
file has a split fork is used.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bike_rig.core.benchmark import PARAMETER_NAMES, SPLIT_PART_NAMES
from bike_rig.core.io_bp import read_bp_measured, read_bp_parameters
from bike_rig.core.measurements import fork_is_split
from test.support.cli import bad, run
from test.support.paper import shared_dir

BP_DATA = shared_dir() / "data" / "bicycleparameters"
SPLIT_BIKES = sorted(
    p.name
    for p in BP_DATA.iterdir()
    if (p / "RawData" / f"{p.name}Measured.txt").is_file()
    and (p / "Parameters" / f"{p.name}Benchmark.txt").is_file()
    and fork_is_split(read_bp_measured(p / "RawData" / f"{p.name}Measured.txt").readings)
)


def _raw(bike: str) -> Path:
    return BP_DATA / bike / "RawData" / f"{bike}Measured.txt"


def _ref(bike: str) -> Path:
    return BP_DATA / bike / "Parameters" / f"{bike}Benchmark.txt"


def test_rigid_is_among_the_split_bicycles() -> None:
    assert "Rigid" in SPLIT_BIKES


@pytest.mark.parametrize("bike", SPLIT_BIKES)
def test_params_json_reports_the_parts_as_bicycleparameters(bike: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "params", str(_raw(bike)), "--json")
    assert code == 0
    doc = json.loads(out)
    assert set(doc["parameters"]) == set(PARAMETER_NAMES)
    assert list(doc["parts"]) == list(SPLIT_PART_NAMES)
    ref = read_bp_parameters(_ref(bike))
    assert ref.parts is not None
    for name in SPLIT_PART_NAMES:
        assert doc["parts"][name]["value"] == pytest.approx(ref.parts.value(name), rel=1e-6), name
    for name in PARAMETER_NAMES:
        assert doc["parameters"][name]["value"] == pytest.approx(ref.parameters.value(name), rel=1e-6), name


@pytest.mark.parametrize("bike", SPLIT_BIKES)
def test_params_table_has_a_per_part_block(bike: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "params", str(_raw(bike)))
    assert code == 0
    assert "per-part outputs (handlebar G, fork S):" in out
    for name in SPLIT_PART_NAMES:
        assert f"\n{name} [" in out, name
    assert "fork S" in out.split("mass centres")[1] and "handlebar G" in out.split("mass centres")[1]


@pytest.mark.parametrize("bike", SPLIT_BIKES)
def test_measurement_yaml_round_trip(bike: str, capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    dest = tmp_path / "refined.yaml"
    code, _, _ = run(capsys, "import-bp", str(_raw(bike)), "-o", str(dest))
    assert code == 0
    text = dest.read_text()
    assert "surface_plate:" in text and "fork_only:" in text and "handlebar:" in text and "\nfork:" not in text
    code, out_yaml, _ = run(capsys, "params", str(dest), "--json")
    code2, out_txt, _ = run(capsys, "params", str(_raw(bike)), "--json")
    assert code == code2 == 0
    a, b = json.loads(out_yaml), json.loads(out_txt)
    for group in ("parameters", "parts"):
        for name, vs in b[group].items():
            assert a[group][name]["value"] == vs["value"], name
            assert a[group][name]["sigma"] == pytest.approx(vs["sigma"], rel=1e-12), name


def test_parameter_yaml_keeps_the_parts(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    dest = tmp_path / "rigid_params.yaml"
    code, _, _ = run(capsys, "params", str(_raw("Rigid")), "--format", "yaml", "-o", str(dest))
    assert code == 0 and "\nparts:" in dest.read_text()
    code, out, _ = run(capsys, "params", str(dest), "--json")
    assert code == 0
    doc = json.loads(out)
    ref = read_bp_parameters(_ref("Rigid"))
    assert ref.parts is not None
    for name in SPLIT_PART_NAMES:
        assert doc["parts"][name]["value"] == pytest.approx(ref.parts.value(name), rel=1e-6), name


def _without(tmp_path: Path, *prefixes: str, name: str = "Cut") -> Path:
    lines = _raw("Rigid").read_text().splitlines()
    kept = [ln for ln in lines if ln.split("=")[0].strip() not in prefixes]
    assert len(kept) == len(lines) - len(prefixes)
    dest = tmp_path / f"{name}Measured.txt"
    dest.write_text("\n".join(kept) + "\n")
    return dest


def test_missing_surface_plate_height(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bad(capsys, _without(tmp_path, "h4"), "key 'h4'", "surface-plate geometry", "h1..h5")


def test_missing_all_geometry_names_both_ways(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    keys = ("h1", "h2", "h3", "h4", "h5", "d1", "d2", "d3", "d4", "d")
    bad(capsys, _without(tmp_path, *keys), "key 'w'", "(w, gamma, f)", "surface-plate", "h1..h5")


def test_missing_handlebar_period(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bad(capsys, _without(tmp_path, "TcG1"), "key 'TcG1'", "handlebar (G)")


def test_missing_handlebar_reference(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bad(capsys, _without(tmp_path, "l"), "key 'l'", "handlebar reference")


def test_two_handlebar_orientations(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bad(capsys, _without(tmp_path, "alphaG3", "aG3", "TtG3"), "handlebar (G): 2 hanging orientation(s)")


def test_split_and_combined_fork_together(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    dest = tmp_path / "MixedMeasured.txt"
    dest.write_text(_raw("Rigid").read_text() + "TcH1 = 1.2+/-0.001\n")
    bad(capsys, dest, "key 'TcH1'", "measured separately")
