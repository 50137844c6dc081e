"""Every command that reads parameters refuses impossible ones in one line, and warns of (or refuses) wrong units."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from bike_rig.cli.main import main
from bike_rig.config.paths import config_file
from test.support.paper import shared_dir

BENCHMARK = config_file("bicycles/benchmark.yaml")
#: The commands and how each names its input.
COMMANDS: tuple[tuple[str, ...], ...] = (("params",), ("model",), ("budget",), ("report", "-o", "{out}"))


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def command(cmd: tuple[str, ...], path: Path, tmp_path: Path, *extra: str) -> list[str]:
    return [cmd[0], str(path), *(a.format(out=tmp_path / "report") for a in cmd[1:]), *extra]


def measured(tmp_path: Path, key: str, text: str) -> Path:
    src = (shared_dir() / "data" / "bicycleparameters" / "Browser" / "RawData" / "BrowserMeasured.txt").read_text()
    out, n = re.subn(rf"^{key} = .*$", f"{key} = {text}", src, flags=re.M)
    assert n == 1
    path = tmp_path / f"{key}Measured.txt"
    path.write_text(out)
    return path


def parameter_file(tmp_path: Path, key: str, value: float) -> Path:
    out, n = re.subn(rf"^  {key}: \[.*\]$", f"  {key}: [{value!r}, 0.0]", BENCHMARK.read_text(), flags=re.M)
    assert n == 1
    path = tmp_path / f"p_{key}.yaml"
    path.write_text(out)
    return path


@pytest.mark.parametrize("cmd", COMMANDS, ids=lambda c: c[0])
def test_a_compound_period_too_short_is_one_line_naming_the_readings(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, cmd: tuple[str, ...]
) -> None:
    path = measured(tmp_path, "TcR1", "0.1+/-0.001")
    code, out, err = run(capsys, *command(cmd, path, tmp_path))
    assert (code, out) == (2, "")
    need = 2 * math.pi * math.sqrt(0.29325 / 9.81)
    assert err.count("\n") == 1 and err.startswith(f"bike-rig {cmd[0]}: error: {path}: bicycle 'TcR1'")
    assert "TcR1 = 0.1 s with lR = 0.29325 m gives IRyy = -0.26518 kg m²: a compound period of at least" in err
    assert f"at least {need:.4g} s is needed" in err
    assert "Traceback" not in err and "Warning" not in err


@pytest.mark.parametrize(
    ("key", "value"), [("w", 0.0), ("rR", 0.0), ("lam", math.pi / 2), ("lam", 7.0), ("g", -9.81), ("mB", 0.0)]
)
def test_an_impossible_parameter_file_is_one_line_with_no_numpy_warning(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, key: str, value: float
) -> None:
    path = parameter_file(tmp_path, key, value)
    for cmd in COMMANDS:
        code, out, err = run(capsys, *command(cmd, path, tmp_path))
        assert (code, out) == (2, ""), cmd
        lines = [e for e in err.splitlines() if ": warning: " not in e]
        assert len(lines) == 1 and lines[0].startswith(f"bike-rig {cmd[0]}: error: {path}: parameter set"), err
        assert f"{key} = " in lines[0] and "RuntimeWarning" not in err


def test_a_wheelbase_in_mm_warns_with_the_corrected_value_and_strict_refuses_it(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    path = measured(tmp_path, "w", "1121+/-2")
    warning = (
        f"{path}:26: w = 1121 m is outside the plausible wheelbase (0.5 to 2.5 m): it looks like millimetres "
        f"(w = 1.121 m)"
    )
    assert path.read_text().splitlines()[25].startswith("w = ")
    for cmd in COMMANDS:
        code, out, err = run(capsys, *command(cmd, path, tmp_path))
        assert code == 0, (cmd, err)
        assert f"bike-rig {cmd[0]}: warning: {warning}\n" in err
        if cmd[0] == "report":  # and in the report's notes
            assert "it looks like millimetres (w = 1.121 m)" in (tmp_path / "report" / "index.html").read_text()
        code, out, err = run(capsys, *command(cmd, path, tmp_path, "--strict"))
        assert (code, out, err) == (2, "", f"bike-rig {cmd[0]}: error: {warning}\n")


@pytest.mark.parametrize(
    ("key", "text", "likely"),
    [("mF", "2020+/-20", "grams (mF = 2.02 kg)"), ("gamma", "1.171+/-0.0035", "radians (gamma = 67.0934 deg)")],
)
def test_a_mass_in_grams_or_an_angle_in_radians_is_named_or_refused(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, key: str, text: str, likely: str
) -> None:
    path = measured(tmp_path, key, text)
    code, out, err = run(capsys, "model", str(path), "--strict")
    assert (code, out) == (2, "")
    assert err.startswith(f"bike-rig model: error: {path}:") and err.endswith(f"it looks like {likely}\n")
    code, out, err = run(capsys, "params", str(path))
    assert f"bike-rig params: warning: {path}:" in err and f"it looks like {likely}" in err


def test_an_impossible_rider_file_is_one_line(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    rider = tmp_path / "rider.yaml"
    rider.write_text("mass: 72\nx: 0.3\nz: -1.2\nIxx: 7.0\nIyy: 15.0\nIzz: 2.0\nIxz: 1.0\n")
    for cmd in (("model",), ("params",), ("budget",)):
        code, out, err = run(capsys, *command(cmd, BENCHMARK, tmp_path, "--rider", str(rider)))
        assert (code, out) == (2, "")
        assert err.startswith(f"bike-rig {cmd[0]}: error: {rider}: not physically possible: ") and err.count("\n") == 1
        assert "break the triangle inequality" in err
