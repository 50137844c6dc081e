"""``bike-rig run`` before anything starts, and what it prints (no node process here).

Mistakes end in one line with exit status 2 and nothing started or created; the result lines
and the summary come from the listener's records (:class:`bike_rig.cli.run_cmd.RunTracker`).
The live runs are in ``test_run_live.py``.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from bike_rig.cli.main import main
from bike_rig.cli.run_cmd import RunTracker, result_lines, session_folder
from bike_rig.config.paths import config_dir, config_file
from bike_rig.core.benchmark import ComMethod, ParameterSet
from bike_rig.core.period.advice import FLAG_ADVICE
from bike_rig.core.period.result import FlagCode
from bike_rig.core.uncertainty.speed_sigma import SpeedWithSigma
from bike_rig.core.whipple import EigenvalueSweep, eigenvalues
from bike_rig.pipeline.acquire import TrialEventKind, TrialEventRecord
from bike_rig.pipeline.assemble import SessionParameters
from bike_rig.pipeline.fit import TrialFit
from bike_rig.pipeline.model import StabilitySweep
from bike_rig.ros.launch import LaunchError, load_graph


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(["run", *argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def here(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty current directory (nothing may be created in it by a refused run)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("ROS_DOMAIN_ID", raising=False)
    return tmp_path


# ------------------------------------------------------------------------------- refused before the start
def test_unknown_param_names_the_nodes_parameters(here: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = _run(capsys, "--param", "driver.tyme_scale=20")
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(
        "bike-rig run: error: node 'driver' has no parameter 'tyme_scale' (did you mean "
        "'time_scale'?); its parameters: source, frame_id, "
    )
    assert "time_scale" in lines[0].split("its parameters:")[1] and "bicycle" in lines[0]
    assert list(here.iterdir()) == []  # no session folder, no log


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["--param", "fitter.min_cyclez=3"],
            "node 'fitter' has no parameter 'min_cyclez' (did you mean 'min_cycles'?)",
        ),
        (["--param", "nodex.a=1"], "no node named 'nodex' (nodes: driver, fitter, model, parameter, recorder)"),
        (["--param", "driver.time_scale=fast"], "node 'driver': parameter 'time_scale' = 'fast': expected a number"),
        (["--param", "driver.time_scale=5000"], "node 'driver': parameter 'time_scale' = 5000: must be <= 1000"),
        (["--param", "driver.source=nope"], "node 'driver': parameter 'source' = 'nope': expected one of sim, can"),
        (["--param", "oops"], "--param expects NODE.NAME=VALUE, got 'oops'"),
        (["--domain-id", "102"], "--domain-id=102 is outside 0..101, the domain ids Fast DDS supports on Linux"),
        (["--domain-id", "-1"], "--domain-id=-1 is outside 0..101"),
        (["--domain-id", "seven"], "--domain-id='seven' is not an integer in 0..101"),
        (
            ["--param", "driver.bicycle=nowhere.yaml"],
            "node 'driver': parameter 'bicycle' = 'nowhere.yaml': no such file (looked in ",
        ),
        (["--config", "nowhere.yaml"], "nowhere.yaml: cannot read the file"),
        (["--without", "drivr"], "no node named 'drivr' (nodes: recorder, fitter, parameter, model, driver)"),
        (["--only", "driver", "--without", "driver"], "no node left to start"),
        (["--only", "driver", "--peer", "rig.local"], "static peer 'rig.local' is not an IP address"),
    ],
)
def test_mistakes_are_one_line_and_start_nothing(
    argv: list[str], message: str, here: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = _run(capsys, *argv)
    lines = err.strip().splitlines()
    assert (code, out, len(lines)) == (2, "", 1), err
    assert lines[0].startswith("bike-rig run: error: ") and message in lines[0], err
    assert list(here.iterdir()) == []


@pytest.mark.parametrize("command", [["run"], ["demo", "--out", "d"]])
def test_a_domain_id_above_101_in_the_environment_is_one_line(
    command: list[str], here: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("ROS_DOMAIN_ID", "150")
    code = main(command)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert lines[0] == (
        f"bike-rig {command[0]}: error: ROS_DOMAIN_ID=150 in the environment is outside 0..101, the domain ids "
        "Fast DDS supports on Linux"
    )
    assert "Traceback" not in err


def test_an_existing_output_or_session_folder_is_refused(here: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (here / "taken").mkdir()
    (here / "taken" / "x").write_text("")
    code, _, err = _run(capsys, "--out", "taken")
    assert code == 2 and "--out taken: exists and is not an empty folder" in err
    code, _, err = _run(capsys, "--param", "recorder.output=taken")
    assert code == 2 and "node 'recorder': parameter 'output' = 'taken': " in err and "never overwritten" in err
    assert sorted(p.name for p in here.iterdir()) == ["taken"]


# ------------------------------------------------------------------------------- the graph's file parameters
def test_relative_paths_resolve_against_the_current_directory_then_the_config_folder(here: Path) -> None:
    (here / "rig.yaml").write_text(config_file("rig.yaml").read_text())  # shadows config/rig.yaml
    (here / "sub").mkdir()
    graph = load_graph(config_file("graph.yaml")).with_parameters(
        {
            "driver": {"rig": "rig.yaml", "bicycle": "bicycles/fisher.yaml", "time_scale": 20},
            "recorder": {"output": "sub/bag"},
        }
    )
    driver = graph.checked().node("driver").parameters
    assert driver["rig"] == str(here / "rig.yaml")  # the current directory first
    assert driver["bicycle"] == str(config_dir() / "bicycles" / "fisher.yaml")  # the config folder as fallback
    assert driver["time_scale"] == 20.0 and isinstance(driver["time_scale"], float)  # an int for a double
    assert graph.checked().node("recorder").parameters["output"] == str(here / "sub" / "bag")
    # a value of the shipped parameter file is found the same way
    shipped = graph.checked().node("parameter").parameters["measurements"]
    assert shipped == str(config_dir() / "bicycles" / "browser.yaml")
    # the default graph simulates Browser; a session given replaces the bicycle
    default = load_graph(config_file("graph.yaml")).checked().node("driver").parameters
    assert default["bicycle"] == str(config_dir() / "bicycles" / "browser.yaml")
    (here / "s.yaml").write_text("x: 1\n")
    session = load_graph(config_file("graph.yaml")).with_parameters({"driver": {"session": "s.yaml"}})
    driver = session.checked().node("driver").parameters
    assert (driver["bicycle"], driver["session"]) == ("", str(here / "s.yaml"))


def test_a_parameter_file_with_an_unknown_name_is_refused(here: Path) -> None:
    (here / "fitter.yaml").write_text("fitter:\n  ros__parameters:\n    min_r3: 0.5\n")
    (here / "graph.yaml").write_text(
        "format: bike_rig-graph/1\nnodes:\n  - {name: fitter, module: bike_rig.ros.nodes.fitter, params: fitter.yaml}\n"
    )
    message = r"fitter.yaml: node 'fitter' has no parameter 'min_r3' \(did you mean 'min_r2'"
    with pytest.raises(LaunchError, match=message):
        load_graph(here / "graph.yaml").checked()


def test_session_folder_default_is_new(here: Path) -> None:
    now = (2026, 11, 25, 10, 0, 0, 0, 0, 0)
    import time

    first = session_folder(None, time.struct_time(now))
    assert first == Path("bike_rig_sessions/20261125-100000")
    first.mkdir(parents=True)
    assert session_folder(None, time.struct_time(now)) == Path("bike_rig_sessions/20261125-100000-2")
    assert session_folder("new") == Path("new") and not Path("new").exists()


# ------------------------------------------------------------------------------- what is printed
def _fit(trial_id: str, key: str, flags: tuple[str, ...] = (), n: int = 15_000, valid: bool = True) -> TrialFit:
    reasons = tuple(f"reason of {f}" for f in flags)
    return TrialFit.from_period(
        trial_id, key, 1.5, 2.5e-5, valid, flags, reasons, r2=0.99876, n_samples=n, window=(1000, 14_500)
    )


def _event(kind: TrialEventKind, trial_id: str, key: str, count: int = 0) -> TrialEventRecord:
    return TrialEventRecord(kind, trial_id, key, sample_rate_hz=1000.0, sample_count=count)


def test_each_result_is_printed_once_with_flags_reasons_and_advice() -> None:
    tr = RunTracker()
    assert tr.add(_event(TrialEventKind.START, "a", "TcR1")) == ["trial a (TcR1): recording"]
    assert tr.add(_event(TrialEventKind.STOP, "a", "TcR1", 15_000)) == []
    assert tr.pending() == ["a"]
    assert tr.add(_fit("a", "TcR1")) == ["trial a (TcR1): T = 1.500000 ± 0.000025 s, 9 cycles, r² 0.99876 - ok"]
    assert tr.pending() == []
    assert tr.add(_fit("a", "TcR1", n=15_001)) == []  # a re-publication (restarted fitter) is not printed again
    tr.add(_event(TrialEventKind.START, "b", "TtB2"))
    lines = tr.add(_fit("b", "TtB2", ("beating", "clipped")))
    assert lines == [
        "trial b (TtB2): T = 1.500000 ± 0.000025 s, 9 cycles, r² 0.99876 - REDO",
        f"    beating: reason of beating -> {FLAG_ADVICE[FlagCode.BEATING]}",
        f"    clipped: reason of clipped -> {FLAG_ADVICE[FlagCode.CLIPPED]}",
    ]
    tr.add(_event(TrialEventKind.START, "c", "TtB3"))
    assert tr.add(_event(TrialEventKind.ABORT, "c", "TtB3", 700)) == ["trial c (TtB3): ABORTED after 700 samples"]
    assert tr.add(_fit("c", "TtB3", ("aborted",), valid=False))[0] == "trial c (TtB3): no period - REDO"
    tr.add(_event(TrialEventKind.START, "d", "TtB3"))
    summary = tr.summary()
    assert summary[0] == "4 trial(s): 1 ok, 2 to redo, 1 without a result"
    assert summary[1] == "  REDO b (TtB2): beating: reason of beating; clipped: reason of clipped"
    assert summary[2] == "  REDO c (TtB3): aborted: reason of aborted"
    assert summary[3] == "  without a result: d"
    assert summary[4] == "parameters: none published"


def test_every_flag_code_has_advice() -> None:
    assert set(FLAG_ADVICE) == set(FlagCode)
    assert all(text and "\n" not in text for text in FLAG_ADVICE.values())


def test_the_parameter_set_is_announced_once_complete_with_the_speeds() -> None:
    tr = RunTracker()
    incomplete = SessionParameters("Browser", ComMethod.CENTROID, (), ("TcR1", "TtR1"))
    assert tr.add(incomplete) == []
    assert tr.summary()[-1] == "parameters: incomplete (Browser); missing: TcR1, TtR1"
    sweep = StabilitySweep("Browser", "", _sweep(), SpeedWithSigma(4.1954, 0.0451), SpeedWithSigma(4.35, math.nan))
    complete = SessionParameters("Browser", ComMethod.CENTROID, (), (), parameters=_parameter_set())
    assert tr.add(complete) == []  # no model yet
    assert tr.add(sweep) == [
        "parameter set complete: weave speed 4.20 ± 0.05 m/s, "
        "capsize speed 4.350000 m/s (σ undefined: not a simple root)"
    ]
    assert tr.add(sweep) == [] and tr.add(complete) == []
    # the model may arrive before its set (two processes): said once both are in
    late = RunTracker()
    assert late.add(incomplete) == [] and late.add(sweep) == []
    assert late.add(complete) == [f"parameter set complete: {late.speeds_text()}"]
    assert tr.summary()[-1].startswith("parameters: complete (Browser); weave speed 4.20 ± 0.05 m/s")


def _parameter_set() -> ParameterSet:
    from bike_rig.core.benchmark import compute_parameters
    from bike_rig.core.loader import load_measurements

    return compute_parameters(load_measurements(config_file("bicycles/browser.yaml")))


def _sweep() -> EigenvalueSweep:
    from bike_rig.core.benchmark import compute_parameters
    from bike_rig.core.loader import load_measurements
    from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma

    ms = canonical_with_sigma(compute_parameters(load_measurements(config_file("bicycles/browser.yaml"))))
    return eigenvalues(ms.matrices, ms.g, np.array([1.0]))


def test_a_result_without_a_known_rate_leaves_out_the_cycles() -> None:
    line = result_lines("x", "", _fit("x", ""))[0]
    assert line == "trial x (?): T = 1.500000 ± 0.000025 s, r² 0.99876 - ok"
    assert os.linesep not in line


def test_awaited_are_results_the_set_that_holds_them_and_its_model() -> None:
    from bike_rig.pipeline.assemble import KeyPeriod

    tr = RunTracker()
    assert tr.awaiting() == []
    for trial, key in (("a", "TcR1"), ("b", "TtR1"), ("c", "TtB2")):
        tr.add(_event(TrialEventKind.START, trial, key))
        tr.add(_event(TrialEventKind.STOP, trial, key, 15_000))
    assert tr.awaiting() == ["3 trial result(s)"]
    tr.add(_fit("a", "TcR1"))
    tr.add(_fit("b", "TtR1"))
    tr.add(_fit("c", "TtB2", ("beating",)))  # flagged: it enters no set
    assert tr.awaiting() == ["the parameter set (2 result(s) not in it yet)"]  # (none published yet)
    assert tr.awaiting(parameters=False) == []  # a graph without a parameter node
    held_a = SessionParameters(
        "Browser", ComMethod.CENTROID, (KeyPeriod("TcR1", 1.5, 2.5e-5, ("a",)),), ("TtR1", "TtB2")
    )
    tr.add(held_a)
    assert tr.awaiting() == ["the parameter set (1 result(s) not in it yet)"]
    periods = (KeyPeriod("TcR1", 1.5, 2.5e-5, ("a",)), KeyPeriod("TtR1", 1.5, 2.5e-5, ("b",)))
    tr.add(SessionParameters("Browser", ComMethod.CENTROID, periods, (), parameters=_parameter_set()))
    assert tr.awaiting() == ["the model of the complete parameter set"]
    assert tr.awaiting(model=False) == []
    tr.add(StabilitySweep("Browser", "", _sweep(), SpeedWithSigma(4.1954, 0.0451), SpeedWithSigma(4.35, 0.06)))
    assert tr.awaiting() == []
