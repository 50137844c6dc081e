"""``bike-rig budget``: the text table, the JSON object, the rider and the user errors."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest
import yaml

from bike_rig.cli.main import main
from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.feedback import load_feedback
from bike_rig.core.loader import load_measurements
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.uncertainty.budget import BUDGET_PARAMETERS, CAPSIZE, WEAVE, reading_names, uncertainty_budget
from bike_rig.core.uncertainty.speed_sigma import critical_speeds_with_sigma
from test.support.paper import shared_dir

BROWSER = str(config_file("bicycles/browser.yaml"))
BENCHMARK = str(config_file("bicycles/benchmark.yaml"))


def run_json(capsys: pytest.CaptureFixture[str], *args: str) -> dict:
    assert main(["budget", *args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_json_is_the_whole_budget(capsys: pytest.CaptureFixture[str]) -> None:
    data = run_json(capsys, BROWSER)
    assert data["bicycle"] == "Browser" and data["input_kind"] == "raw readings"
    assert "TtB1" in data["input_keys"] and "alphaB2" in data["input_keys"]
    names = [o["output"] for o in data["outputs"]]
    assert names == [*BUDGET_PARAMETERS, WEAVE, CAPSIZE]
    for o in data["outputs"]:
        assert math.fsum(s["share"] for s in o["shares"]) == pytest.approx(1.0, abs=1e-12)
    weave = data["outputs"][names.index(WEAVE)]
    assert weave["unit"] == "m/s" and weave["sigma"] > 0
    # The same numbers as the core's budget.
    core = uncertainty_budget(compute_parameters(load_measurements(BROWSER))).output(WEAVE)
    assert weave["sigma"] == core.sigma and weave["shares"][0]["key"] == core.shares[0].input


def test_rider_and_com_method_change_the_budget(capsys: pytest.CaptureFixture[str]) -> None:
    bare = run_json(capsys, BROWSER)
    ridden = run_json(capsys, BROWSER, "--rider", "paper")
    lstsq = run_json(capsys, BROWSER, "--com-method", "lstsq")
    assert ridden["bicycle"] == f"Browser + {PAPER_RIDER.name}"
    want = uncertainty_budget(add_rider(compute_parameters(load_measurements(BROWSER)), PAPER_RIDER))
    assert ridden["outputs"][-2]["value"] == want.output(WEAVE).value
    assert ridden["outputs"][-2]["value"] != bare["outputs"][-2]["value"]
    xb = BUDGET_PARAMETERS.index("xB")
    assert lstsq["outputs"][xb]["value"] != bare["outputs"][xb]["value"]


def test_text_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["budget", BROWSER, "--top", "2"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].startswith("Browser: uncertainty budget over 40 raw readings")
    assert lines[1].startswith("measure better first")
    heading = next(i for i, line in enumerate(lines) if line.startswith("weave speed [m/s]: "))
    block = lines[heading + 1 : heading + 4]
    assert [line.startswith("    ") for line in block] == [True, True, True]
    assert block[2].lstrip().startswith("...")  # only the top 2, then the rest summed
    m = load_measurements(BROWSER)
    top = uncertainty_budget(compute_parameters(m), reading_names(m)).output(WEAVE).shares[0]
    assert block[0].split()[0] == top.input and f"{100 * top.share:.1f} %" in block[0]
    for name in BUDGET_PARAMETERS:
        assert any(line.startswith(f"{name} [") for line in lines), name


def test_parameter_file_and_output_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "budget.txt"
    assert main(["budget", BENCHMARK, "-o", str(target)]) == 0
    assert capsys.readouterr().out == ""
    text = target.read_text(encoding="utf-8")
    assert "over the 26 parameters" in text and "no output has a σ" in text
    data = run_json(capsys, BENCHMARK)
    assert data["input_kind"] == "parameters" and all(o["shares"] == [] for o in data["outputs"])


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["no-such-file.yaml"], "no-such-file.yaml: no such file or directory"),
        ([BROWSER, "--top", "0"], "--top N needs N >= 1"),
    ],
)
def test_user_errors_are_one_line(capsys: pytest.CaptureFixture[str], args: list[str], message: str) -> None:
    assert main(["budget", *args]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and captured.err.startswith("bike-rig budget: error: ")
    assert message in captured.err


def test_rider_file_gives_the_same_budget_as_its_values(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    r = PAPER_RIDER
    path = tmp_path / "rider.yaml"
    path.write_text(
        f"name: {r.name}\nmass: {r.mass!r}\nx: {r.x!r}\nz: {r.z!r}\n"
        f"Ixx: {r.Ixx!r}\nIyy: {r.Iyy!r}\nIzz: {r.Izz!r}\nIxz: {r.Ixz!r}\n"
    )
    assert run_json(capsys, BROWSER, "--rider", str(path)) == run_json(capsys, BROWSER, "--rider", "paper")
    path.write_text("mass: heavy\n")
    assert main(["budget", BROWSER, "--rider", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "rider.yaml" in err[0] and "needs a number" in err[0]


# ---------------------------------------------------------------- input names (issue 11)


def _yaml_value(document: object, label: str) -> object:
    """The value at a key path as written in a YAML measurement file (``fork.orientations[2].distance``)."""
    node = document
    for name, index in re.findall(r"([A-Za-z_]+)|\[(\d+)\]", label):
        node = node[name] if name else node[int(index)]  # type: ignore[index]
    return node


def test_a_yaml_file_names_its_inputs_by_its_own_keys(capsys: pytest.CaptureFixture[str]) -> None:
    data = run_json(capsys, BROWSER)
    named = dict(zip(data["input_keys"], data["inputs"]))
    assert named["aH3"] == "fork.orientations[2].distance"
    assert named["alphaB1"] == "frame.orientations[0].angle_deg"
    assert named["mP"] == "calibration_rod.mass" and named["gamma"] == "geometry.head_tube_angle_deg"
    assert named["TcB1"] == "frame.compound_period" and named["g"] == "gravity"
    document = yaml.safe_load(Path(BROWSER).read_text(encoding="utf-8"))
    m = load_measurements(BROWSER)
    for key, label in named.items():  # every name is a path into the file, to that reading
        assert list(_yaml_value(document, label)) == [m.readings[key].value, m.readings[key].sigma], label
    # Only the names differ from the BicycleParameters-keyed budget.
    core = uncertainty_budget(compute_parameters(m))
    weave = data["outputs"][[o["output"] for o in data["outputs"]].index(WEAVE)]
    assert [(s["key"], s["share"]) for s in weave["shares"]] == [(s.input, s.share) for s in core.output(WEAVE).shares]
    assert all(s["input"] == named[s["key"]] for s in weave["shares"])
    assert main(["budget", BROWSER, "--top", "3"]) == 0
    text = capsys.readouterr().out
    assert "    fork.orientations[2].distance " in text and "aH3" not in text


def test_a_measured_txt_keeps_bicycleparameters_keys(capsys: pytest.CaptureFixture[str]) -> None:
    measured = shared_dir() / "data" / "bicycleparameters" / "Browser" / "RawData" / "BrowserMeasured.txt"
    data = run_json(capsys, str(measured))
    assert data["inputs"] == data["input_keys"] and {"aH3", "mP", "gamma", "TcB1"} <= set(data["inputs"])
    yaml_data = run_json(capsys, BROWSER)
    assert sorted(data["input_keys"]) == sorted(yaml_data["input_keys"])  # the same readings, other names


def test_feedback_budgets_the_closed_loop_speeds(capsys: pytest.CaptureFixture[str]) -> None:
    """``--feedback``: the speeds are the closed loop's, their σ the parameter covariance's (gains exact)."""
    assist = config_file("feedback/balance_assist.yaml")
    data = run_json(capsys, BROWSER, "--feedback", str(assist))
    assert data["feedback"] == "balance assist" and "feedback" not in run_json(capsys, BROWSER)
    cs = critical_speeds_with_sigma(compute_parameters(load_measurements(BROWSER)), feedback=load_feedback(assist))
    outputs = {o["output"]: o for o in data["outputs"]}
    for name, speed in ((WEAVE, cs.weave), (CAPSIZE, cs.capsize)):
        assert speed is not None
        assert outputs[name]["value"] == speed.speed
        assert outputs[name]["sigma"] == pytest.approx(speed.sigma, rel=1e-9)
        assert sum(s["share"] for s in outputs[name]["shares"]) == pytest.approx(1.0)
    assert outputs[WEAVE]["value"] < 2.0  # the assist's low-speed stabilisation
    assert main(["budget", BROWSER, "--feedback", str(assist)]) == 0
    assert "closed loop with feedback 'balance assist'" in capsys.readouterr().out


def test_feedback_gains_with_sigma_are_budget_inputs(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """A gain given with σ is one more input of the speeds' budget; its σ equals the speeds' σ."""
    path = tmp_path / "fb.yaml"
    path.write_text(
        "format: bike_rig-feedback/1\nk_phidot: {speeds: [0, 5], values: [-50, 0], sigmas: [5, 0]}\n"
        "k_phi: {speeds: [5, 15], values: [0, -5]}\n"
    )
    data = run_json(capsys, BROWSER, "--feedback", str(path))
    assert data["inputs"][-1] == "feedback.k_phidot.values[0]"
    cs = critical_speeds_with_sigma(compute_parameters(load_measurements(BROWSER)), feedback=load_feedback(path))
    outputs = {o["output"]: o for o in data["outputs"]}
    assert cs.weave is not None
    assert outputs[WEAVE]["sigma"] == pytest.approx(cs.weave.sigma, rel=1e-9)
    shares = {s["input"]: s["share"] for s in outputs[WEAVE]["shares"]}
    assert shares["feedback.k_phidot.values[0]"] > 0.0
    assert all("feedback." not in s["input"] for s in outputs["w"]["shares"])  # parameters do not depend on it
