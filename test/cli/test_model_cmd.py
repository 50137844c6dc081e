"""``bike-rig model``: the critical speeds with σ from the code the model node uses (issue 11)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bike_rig.cli import model_cmd
from bike_rig.cli.commands import COMMANDS
from bike_rig.cli.main import main
from bike_rig.config.paths import config_dir
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.feedback import load_feedback
from bike_rig.core.loader import load_measurements
from bike_rig.core.textfmt import format_value_sigma
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import state_space
from bike_rig.pipeline.model import compute_model
from test.support.cli import run

BROWSER_YAML = config_dir() / "bicycles" / "browser.yaml"


def test_model_is_its_own_module() -> None:
    registrar = {c.name: c.registrar for c in COMMANDS}["model"]
    assert registrar == "model_cmd" and callable(model_cmd.add_parser)


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
            value, sig = format_value_sigma(speed.speed, speed.sigma, digits=None)
            line = next(line for line in out.splitlines() if line.startswith(f"{name} speed:"))
            assert line.split(":", 1)[1].strip() == f"{value} ± {sig} m/s"
    code, out, _ = run(capsys, "model", str(BROWSER_YAML))
    assert "weave speed:   4.20 ± 0.05 m/s" in out and "capsize speed: 4.35 ± 0.06 m/s" in out  # σ by the PDG rule


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


ASSIST_YAML = config_dir() / "feedback" / "balance_assist.yaml"


def test_model_feedback_is_the_closed_loop(capsys: pytest.CaptureFixture[str]) -> None:
    """``--feedback``: eigenvalues of ``A − B K`` (checked by eigvals), closed-loop speeds with σ as the pipeline's."""
    ps = compute_parameters(load_measurements(BROWSER_YAML))
    argv = ["model", str(BROWSER_YAML), "--json", "--feedback", str(ASSIST_YAML), "--speeds", "0", "8", "33"]
    code, out, _ = run(capsys, *argv)
    assert code == 0
    doc = json.loads(out)
    speeds = np.array(doc["speeds"])
    gains = np.array(doc["feedback"]["gains"])
    assert doc["feedback"]["name"] == "balance assist" and gains.shape == (33, 4)
    ms = canonical_with_sigma(ps)
    a, b = state_space(ms.matrices, speeds, ms.g)
    k = np.zeros((33, 2, 4))
    k[:, 1, :] = load_feedback(ASSIST_YAML).gains(speeds)
    ref = np.linalg.eigvals(a - b @ k)
    ours = np.array([[z["re"] + 1j * z["im"] for z in row] for row in doc["eigenvalues"]])
    assert np.abs(ours[:, :, None] - ref[:, None, :]).min(axis=2).max() < 1e-9
    _, sweep = compute_model(ps, speeds, feedback=str(ASSIST_YAML))
    assert sweep.feedback == str(ASSIST_YAML) and sweep.weave is not None
    assert (doc["weave_speed"], doc["weave_speed_sigma"]) == (sweep.weave.speed, sweep.weave.sigma)
    # The assist stabilises 2 m/s, where the open loop is unstable (weave speed above 4 m/s).
    assert ref[speeds == 2.0].real.max() < 0.0 and doc["open_loop"]["weave_speed"] > 2.0
    assert any(lo < 2.0 < (hi or np.inf) for lo, hi in doc["stable_speed_ranges"])
    code, out, _ = run(capsys, "model", str(BROWSER_YAML), "--feedback", str(ASSIST_YAML))
    assert "closed loop with feedback 'balance assist'" in out and "stable speeds (closed loop):" in out


def test_model_without_feedback_is_unchanged(capsys: pytest.CaptureFixture[str]) -> None:
    """No ``--feedback`` (or ``none``): the open loop's output, without the feedback keys."""
    _, plain, _ = run(capsys, "model", str(BROWSER_YAML), "--json")
    _, none, _ = run(capsys, "model", str(BROWSER_YAML), "--json", "--feedback", "none")
    assert plain == none and "feedback" not in json.loads(plain)


def test_model_bad_feedback_file_is_one_line(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """A bad feedback file ends in one line naming the file, line and key, exit status 2."""
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: bike_rig-feedback/1\nk_phi: {speeds: [2, 1], values: [0, 1]}\n")
    code, out, err = run(capsys, "model", str(BROWSER_YAML), "--feedback", str(bad))
    assert code == 2 and out == ""
    reason = "speeds must increase strictly (2 then 1 m/s)"
    assert err == f"bike-rig model: error: {bad}:2: key 'k_phi.speeds[1]': {reason}\n"
