"""Nearly parallel hanging lines: ``budget`` and ``params`` print the Monte Carlo σ and say so."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from bike_rig.cli.main import main
from bike_rig.config.paths import config_file

DATA = Path("/work/shared/data/bicycleparameters")


def _raw(name: str) -> str:
    path = DATA / name / "RawData" / f"{name}Measured.txt"
    if not path.exists():
        pytest.skip(f"{path} not available")
    return str(path)


def _out(capsys: pytest.CaptureFixture[str], *args: str) -> str:
    capsys.readouterr()
    assert main(list(args)) == 0
    return capsys.readouterr().out


def test_rigid_budget_prints_the_monte_carlo_sigma_of_the_frame_mass_centre(
    capsys: pytest.CaptureFixture[str],
) -> None:
    path = _raw("Rigid")
    text = _out(capsys, "budget", path, "--top", "1")
    for name in ("xB", "zB"):
        assert re.search(rf"^{name} \[m\]: \S+ ± \S+\*$", text, re.M), name
    assert re.search(r"^mB \[kg\]: \S+ ± [\d.]+$", text, re.M)
    assert "* σ from a 20,000-draw Monte Carlo (nearly parallel hanging lines: frame 1.2°" in text
    frame = next(x for x in text.splitlines() if x.strip().startswith("frame"))
    assert "nearly parallel" in frame
    outs = {o["output"]: o for o in json.loads(_out(capsys, "budget", path, "--json"))["outputs"]}
    for name in ("xB", "zB"):
        assert outs[name]["sigma_method"] == "monte_carlo"
        assert outs[name]["sigma"] != pytest.approx(outs[name]["sigma_linear"], rel=1e-3)
    assert "sigma_method" not in outs["mB"]


def test_rigid_params_mark_the_monte_carlo_sigma(capsys: pytest.CaptureFixture[str]) -> None:
    path = _raw("Rigid")
    text = _out(capsys, "params", path)
    for label in ("x_B [m]", "z_B [m]"):
        line = next(x for x in text.splitlines() if x.startswith(label))
        assert line.endswith("*"), line
    assert not next(x for x in text.splitlines() if x.startswith("m_B [kg]")).endswith("*")
    assert "* σ from a 20,000-draw Monte Carlo (nearly parallel hanging lines: frame 1.2°" in text
    got = json.loads(_out(capsys, "params", path, "--json"))["parameters"]
    for name in ("xB", "zB"):
        assert got[name]["sigma_method"] == "monte_carlo"
        assert got[name]["sigma"] != pytest.approx(got[name]["sigma_linear"], rel=1e-3)
    assert "sigma_method" not in got["mB"]


def test_well_spread_lines_keep_the_linear_sigma(capsys: pytest.CaptureFixture[str]) -> None:
    text = _out(capsys, "budget", _raw("Browser"), "--top", "1")
    assert "nearly parallel" not in text and "Monte Carlo" not in text and "*" not in text
    for args in ((str(config_file("bicycles/browser.yaml")),), (_raw("Browser"),)):
        assert "*" not in _out(capsys, "params", *args)
        got = json.loads(_out(capsys, "params", *args, "--json"))["parameters"]
        assert not any("sigma_method" in v for v in got.values())
