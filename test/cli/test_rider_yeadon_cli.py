"""A Yeadon rider file on the command line: ``params``, ``model`` and ``budget`` take it; errors are one line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bike_rig.cli.main import main
from bike_rig.core.benchmark import PARAMETER_NAMES, compute_parameters
from bike_rig.core.io_bp import read_bp_measured, read_bp_parameters
from bike_rig.core.rider import add_rider, resolve_rider
from test.support.paper import shared_dir

BP = shared_dir() / "data" / "bicycleparameters"
BROWSER = str(BP / "Browser" / "RawData" / "BrowserMeasured.txt")
JASON = BP / "riders" / "Jason" / "RawData"


def _rider(tmp_path: Path, extra: str = "", somersault: str | None = None) -> str:
    cfg = JASON / "JasonBrowserYeadonCFG.txt"
    if somersault is not None:
        text = cfg.read_text(encoding="utf-8").replace("somersault: 0.175", f"somersault: {somersault}")
        cfg = tmp_path / "cfg.txt"
        cfg.write_text(text, encoding="utf-8")
    path = tmp_path / "jason.yaml"
    path.write_text(
        f"name: Jason\nyeadon_measurements: {JASON / 'JasonYeadonMeas.txt'}\nyeadon_configuration: {cfg}\n{extra}",
        encoding="utf-8",
    )
    return str(path)


def test_params_json_with_a_yeadon_rider(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rider = _rider(tmp_path, "measurement_sigma: 0\nmass_sigma: 0\npose_sigma: false\n")
    assert main(["params", BROWSER, "--rider", rider, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)  # nothing but the JSON object on stdout
    assert data["bicycle"] == "Browser + Jason" and list(data["parameters"]) == list(PARAMETER_NAMES)
    ref = read_bp_parameters(BP / "riders" / "Jason" / "Parameters" / "JasonBrowserBenchmark.txt").parameters
    for name in PARAMETER_NAMES:
        got = data["parameters"][name]
        assert got["value"] == pytest.approx(ref.value(name), rel=1e-6, abs=1e-12), name
        assert got["sigma"] == pytest.approx(ref.sigma(name), rel=1e-3, abs=1e-15), name


def test_model_and_budget_with_a_yeadon_rider(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rider = _rider(tmp_path)
    assert main(["model", BROWSER, "--rider", rider, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    chosen = resolve_rider(rider)
    assert chosen is not None
    want = add_rider(compute_parameters(read_bp_measured(BROWSER)), chosen)
    assert data["M_sigma"][0][0] > 0 and data["weave_speed_sigma"] > 0 and data["capsize_speed_sigma"] > 0
    assert want.parameters.value("mB") == pytest.approx(9.86 + 83.5)
    assert main(["budget", BROWSER, "--rider", rider, "--json"]) == 0
    budget = json.loads(capsys.readouterr().out)
    assert budget["bicycle"] == "Browser + Jason"
    assert "rider totalmass" in budget["input_keys"] and "rider Ls1L" in budget["input_keys"]


def test_unreachable_grip_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rider = _rider(tmp_path, somersault="0.123918377")
    assert main(["params", BROWSER, "--rider", rider, "--json"]) == 2
    out = capsys.readouterr()
    assert out.out == ""
    lines = out.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.err
    assert "left arm cannot reach the grip" in lines[0] and "LhbF = 0.893" in lines[0]


def test_parameter_file_without_geometry_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rider = _rider(tmp_path)
    assert main(["model", str(BP / "Browser" / "Parameters" / "BrowserBenchmark.txt"), "--rider", rider]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "needs the bicycle's rider-geometry keys lst, lsp, lamst" in err[0]


def test_plot_with_a_yeadon_rider(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rider = _rider(tmp_path, "measurement_sigma: 0\nmass_sigma: 0\n")
    assert main(["plot", "eigen", BROWSER, "-o", str(tmp_path / "figs"), "--rider", rider]) == 0
    assert (tmp_path / "figs" / "eigen_rider.png").stat().st_size > 0
    bad = tmp_path / "bad.yaml"
    bad.write_text("yeadon_measurements: nowhere.txt\nyeadon_configuration: nowhere.txt\n", encoding="utf-8")
    assert main(["plot", "eigen", BROWSER, "-o", str(tmp_path / "figs2"), "--rider", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nowhere.txt" in err[0]
    assert not (tmp_path / "figs2").exists() or not any((tmp_path / "figs2").iterdir())


def test_rider_titles() -> None:
    from bike_rig.plots.model_data import rider_title

    assert rider_title("") == "without rider" and rider_title("paper") == "with the paper's rider"
    assert rider_title("/some/where/jason.yaml") == "with the rider of jason.yaml"
