"""The ``bike-rig`` command line.

Outputs and every bad-input case (message, exit status 2, no traceback).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from bike_rig.config.paths import config_dir
from bike_rig.core.benchmark import PARAMETER_NAMES
from test.support.cli import bad, run
from test.support.paper import shared_dir

BROWSER_YAML = config_dir() / "bicycles" / "browser.yaml"


def _browser_txt() -> Path:
    return shared_dir() / "data" / "bicycleparameters" / "Browser" / "RawData" / "BrowserMeasured.txt"


def test_params_json(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "params", str(BROWSER_YAML), "--json")
    assert code == 0
    doc = json.loads(out)
    assert doc["bicycle"] == "Browser"
    assert set(doc["parameters"]) == set(PARAMETER_NAMES)
    assert doc["parameters"]["IBxx"]["value"] == pytest.approx(0.52962890621, rel=1e-9)
    assert doc["parameters"]["IBxx"]["sigma"] == pytest.approx(0.00247550148476, rel=1e-6)
    assert doc["parameters"]["g"] == {"value": 9.81, "sigma": 0.01}


def test_params_table_reads_bp_text_and_reports_com_methods(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "params", str(_browser_txt()))
    assert code == 0
    assert "I_Bxx [kg m²]" in out and "0.530" in out and "0.002" in out
    assert "more accurate: centroid" in out and "used: centroid" in out
    code, out2, _ = run(capsys, "params", str(_browser_txt()), "--com-method", "lstsq")
    assert code == 0 and "used: lstsq" in out2 and out2 != out


def test_params_bp_yaml(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    dest = tmp_path / "browser_bp.yml"
    code, _, _ = run(capsys, "params", str(BROWSER_YAML), "--format", "bp-yaml", "-o", str(dest))
    assert code == 0
    doc = yaml.safe_load(dest.read_text())
    assert doc["parameterization"] == "Meijaard2007" and doc["rider"] is False and "v" in doc["values"]
    code, _, _ = run(capsys, "params", str(BROWSER_YAML), "--rider", "paper", "--format", "bp-yaml", "-o", str(dest))
    assert code == 0
    assert yaml.safe_load(dest.read_text())["rider"] is True


def test_model_json_benchmark(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(
        capsys, "model", str(config_dir() / "bicycles" / "benchmark.yaml"), "--speeds", "0", "10", "3", "--json"
    )
    assert code == 0
    doc = json.loads(out)
    assert doc["M"][0][1] == pytest.approx(2.31941332208709, rel=1e-12)
    assert doc["weave_speed"] == pytest.approx(4.29238253634111, abs=1e-9)
    assert doc["capsize_speed"] == pytest.approx(6.02426201538837, abs=1e-9)
    assert doc["speeds"] == [0.0, 5.0, 10.0]
    assert len(doc["eigenvalues"]) == 3 and len(doc["eigenvalues"][1]) == 4
    at5 = sorted(complex(e["re"], e["im"]).real for e in doc["eigenvalues"][1])
    assert at5[0] == pytest.approx(-14.07838969279822, abs=1e-10)
    assert doc["M_sigma"] == [[0.0, 0.0], [0.0, 0.0]]  # the benchmark's parameters are exact
    for key in ("C1", "K0", "K2", "C1_sigma", "K0_sigma", "K2_sigma"):
        assert len(doc[key]) == 2


def test_model_with_rider_and_sigma_conventions(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "model", str(BROWSER_YAML), "--rider", "paper", "--json")
    assert code == 0
    with_rider = json.loads(out)
    assert with_rider["M"][0][0] == pytest.approx(102.78, abs=0.01)  # paper Table 5, B
    _, out_c, _ = run(capsys, "model", str(BROWSER_YAML), "--json")
    _, out_p, _ = run(capsys, "model", str(BROWSER_YAML), "--json", "--sigma", "paper")
    corr, paper = json.loads(out_c), json.loads(out_p)
    assert corr["M"] == paper["M"] and corr["M_sigma"] != paper["M_sigma"]


def test_import_bp(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    dest = tmp_path / "browser.yaml"
    code, _, err = run(capsys, "import-bp", str(_browser_txt()), "-o", str(dest))
    assert code == 0 and "Browser measurements" in err
    assert dest.read_text() == BROWSER_YAML.read_text()


def test_demo_prints_parameters_and_speeds(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "demo", "--offline")
    assert code == 0
    assert "Browser: benchmark parameters" in out
    assert "weave speed:" in out and "capsize speed:" in out


# ----------------------------------------------------------------------------- bad input


def _edit(tmp_path: Path, source: Path, old: str, new: str, name: str | None = None) -> Path:
    text = source.read_text()
    assert old in text, old
    dest = tmp_path / (name or source.name)
    dest.write_text(text.replace(old, new, 1))
    return dest


def _line_of(path: Path, fragment: str) -> int:
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if fragment in line)


def test_missing_key_bp(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = _edit(tmp_path, _browser_txt(), "TcB1 = 1.71730688911+/-4.98313880734e-06\n", "")
    bad(capsys, path, "key 'TcB1'", "missing")


def test_missing_key_yaml(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    old = "  compound_period: [1.71730688911, 4.98313880734e-06]  # s, swinging about the rear axle\n"
    path = _edit(tmp_path, BROWSER_YAML, old, "")
    bad(capsys, path, "key 'frame.compound_period'", "missing", f":{_line_of(path, 'frame:')}:")


def test_non_numeric_value_bp(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = _edit(tmp_path, _browser_txt(), "mB = 9.86+/-0.02", "mB = heavy+/-0.02")
    bad(capsys, path, "key 'mB'", "not a number", f":{_line_of(path, 'mB = heavy')}:")


def test_non_numeric_value_yaml(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = _edit(tmp_path, BROWSER_YAML, "mass: [9.86, 0.02]", "mass: [nine, 0.02]")
    bad(capsys, path, "key 'frame.mass'", "not a number", f":{_line_of(path, 'mass: [nine')}:")


def test_value_without_sigma_yaml(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = _edit(tmp_path, BROWSER_YAML, "wheelbase: [1.121, 0.002]", "wheelbase: 1.121")
    bad(capsys, path, "key 'geometry.wheelbase'", "no sigma")


@pytest.mark.parametrize("mass", ["0.0", "-9.86"])
def test_zero_or_negative_mass(capsys: pytest.CaptureFixture[str], tmp_path: Path, mass: str) -> None:
    path = _edit(tmp_path, BROWSER_YAML, "mass: [9.86, 0.02]", f"mass: [{mass}, 0.02]")
    bad(capsys, path, "key 'frame.mass'", "must be positive", f":{_line_of(path, f'mass: [{mass}')}:")
    path = _edit(tmp_path, _browser_txt(), "mR = 3.11+/-0.02", f"mR = {mass}+/-0.02")
    bad(capsys, path, "key 'mR'", "must be positive", f":{_line_of(path, 'mR =')}:")


def test_angle_out_of_range(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = _edit(tmp_path, BROWSER_YAML, "head_tube_angle_deg: [67.1, 0.2]", "head_tube_angle_deg: [112.9, 0.2]")
    bad(capsys, path, "key 'geometry.head_tube_angle_deg'", "(0, 90] degrees", f":{_line_of(path, 'head_tube')}:")
    path = _edit(tmp_path, _browser_txt(), "alphaB2 = 138.7+/-0.2", "alphaB2 = 738.7+/-0.2")
    bad(capsys, path, "key 'alphaB2'", "[-360, 360]")


def test_fewer_orientations_than_needed(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    text = BROWSER_YAML.read_text().splitlines(keepends=True)
    # drop the frame's third orientation
    start = next(i for i, line in enumerate(text) if line.startswith("frame:"))
    third = [i for i in range(start, len(text)) if text[i].startswith("    - ")][2]
    path = tmp_path / "two_orientations.yaml"
    path.write_text("".join(text[:third] + text[third + 1 :]))
    bad(capsys, path, "frame: 2 hanging orientation(s) given, at least 3")


def test_parallel_hanging_lines(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = _edit(tmp_path, _browser_txt(), "alphaB3 = 229.8+/-0.2", "alphaB3 = 183.6+/-0.2")
    bad(capsys, path, "frame orientations 1 and 3 hang along parallel lines", "key 'alphaB3'")


def test_unreadable_files(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    bad(capsys, tmp_path / "nope.yaml", "no such file")
    bad(capsys, tmp_path, "not a rosbag2 bag")  # a folder where a bicycle is meant is read as a bag
    binary = tmp_path / "garbage.txt"
    binary.write_bytes(b"\xff\xfe\x00\x81")
    bad(capsys, binary, "cannot read the file")
    broken = tmp_path / "broken.yaml"
    broken.write_text("format: bike_rig-measurements/1\nframe: [unclosed\n")
    bad(capsys, broken, "invalid YAML")
    other = tmp_path / "other.yaml"
    other.write_text("hello: world\n")
    bad(capsys, other, "unknown kind of YAML file")


def test_bad_speeds_and_rider(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    code, _, err = run(capsys, "model", str(BROWSER_YAML), "--speeds", "5", "1", "3")
    assert code == 2 and "START <= STOP" in err
    rider = tmp_path / "rider.yaml"
    rider.write_text("mass: 70\nx: 0.3\nz: -1.1\nIxx: 7\nIyy: 8\nIzz: two\nIxz: -1.9\n")
    code, _, err = run(capsys, "model", str(BROWSER_YAML), "--rider", str(rider))
    assert code == 2 and "key 'Izz'" in err and f"{rider}:6" in err


def test_real_process_exit_status(tmp_path: Path) -> None:
    """Through a real interpreter: exit status 2, one line, no traceback."""
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    proc = subprocess.run(
        [sys.executable, "-m", "bike_rig.cli.main", "params", str(tmp_path / "missing.txt")],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip() == f"bike-rig params: error: {tmp_path / 'missing.txt'}: no such file"
