"""``bike-rig model``: the critical speeds with σ from the code the model node uses (issue 11)."""

from __future__ import annotations

import json

import pytest

from bike_rig.cli import model_cmd
from bike_rig.cli.main import SUBCOMMANDS, main
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.loader import load_measurements
from bike_rig.paths import config_dir
from bike_rig.pipeline.model import compute_model
from bike_rig.textfmt import format_value_sigma

BROWSER_YAML = config_dir() / "bicycles" / "browser.yaml"


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_model_is_its_own_module() -> None:
    assert dict(SUBCOMMANDS)["model"] == "model_cmd" and callable(model_cmd.add_parser)


def test_model_prints_the_critical_speeds_with_the_model_nodes_sigma(capsys: pytest.CaptureFixture[str]) -> None:
    """``model`` shows the weave and capsize speeds with σ, from the code the model node, replay and report use."""
    ps = compute_parameters(load_measurements(BROWSER_YAML))
    for rider, sigma in (("", "correlated"), ("paper", "paper")):
        _, sweep = compute_model(ps, [0.0], rider, sigma)
        assert sweep.weave is not None and sweep.capsize is not None
        extra = ["--rider", rider] if rider else []
        code, out, _ = run(capsys, "model", str(BROWSER_YAML), "--json", "--sigma", sigma, *extra)
        assert code == 0
        doc = json.loads(out)
        assert (doc["weave_speed"], doc["weave_speed_sigma"]) == (sweep.weave.speed, sweep.weave.sigma)
        assert (doc["capsize_speed"], doc["capsize_speed_sigma"]) == (sweep.capsize.speed, sweep.capsize.sigma)
        code, out, _ = run(capsys, "model", str(BROWSER_YAML), "--sigma", sigma, *extra)
        for name, speed in (("weave", sweep.weave), ("capsize", sweep.capsize)):
            value, sig = format_value_sigma(speed.speed, speed.sigma, digits=2)
            line = next(line for line in out.splitlines() if line.startswith(f"{name} speed:"))
            assert line.split(":", 1)[1].strip() == f"{value} ± {sig} m/s"
    code, out, _ = run(capsys, "model", str(BROWSER_YAML))
    assert "weave speed:   4.195 ± 0.045 m/s" in out and "capsize speed: 4.350 ± 0.064 m/s" in out


def test_model_of_exact_parameters_has_zero_sigma(capsys: pytest.CaptureFixture[str]) -> None:
    bench = str(config_dir() / "bicycles" / "benchmark.yaml")
    code, out, _ = run(capsys, "model", bench, "--speeds", "0", "10", "3", "--json")
    doc = json.loads(out)
    assert code == 0 and doc["weave_speed_sigma"] == 0.0 and doc["capsize_speed_sigma"] == 0.0
    code, out, _ = run(capsys, "model", bench, "--speeds", "0", "10", "3")
    assert "weave speed:   4.292383 ± 0 m/s" in out


@pytest.mark.parametrize("speeds", [["0", "1e300", "3"], ["-2000", "0", "3"], ["0", "10", "1000000"]])
def test_speeds_beyond_the_models_reach_are_refused_in_one_line(
    speeds: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    """A speed of 1e300 m/s printed NaN eigenvalues with exit 0."""
    code = main(["model", str(config_dir() / "bicycles" / "browser.yaml"), "--speeds", *speeds])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "at most 1000 m/s either way and 100,000 speeds" in err[0]
