"""Tests of ``bike-rig replay``: offline recomputation from a bag.

Offline recomputation from a bag, against the core path and the recorded live results; other fit
settings; bad input; no rclpy.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bike_rig.bag.errors import NoRigTopicsError, ReplayError
from bike_rig.bag.simulated import SimulatedMessage, live_results, simulated_messages, write_simulated_bag
from bike_rig.config.topics import GYRO, STATIC_READINGS, TRIAL_EVENTS
from bike_rig.core.benchmark import PARAMETER_NAMES, compute_parameters
from bike_rig.core.period import WindowPolicy, combine_periods, fit_period
from bike_rig.core.sim import SimulatedSession
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import critical_speeds
from bike_rig.offline.compare import in_sigma, relative_difference
from bike_rig.offline.replay import FitOverrides, ReplaySettings, replay_bag
from test.support.replay import LIVE_OPTIONS, run_cli

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def raw_bag(session: SimulatedSession, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The session's input stream only.

    As recorded with nothing but the driver and the parameter node's static readings.
    """
    return write_simulated_bag(tmp_path_factory.mktemp("replay") / "raw", session, pause_s=2.0)


@pytest.fixture(scope="module")
def live_bag(session: SimulatedSession, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The stream plus what the live nodes published from it, with non-default fit settings."""
    extra = live_results(simulated_messages(session, pause_s=2.0), LIVE_OPTIONS)
    return write_simulated_bag(tmp_path_factory.mktemp("replay") / "live", session, extra=extra, pause_s=2.0)


def test_replay_equals_the_offline_core_path(session: SimulatedSession, raw_bag: Path) -> None:
    result = replay_bag(raw_bag)
    assert result.complete and result.bicycle == "Browser"
    # the core path: fit each trial's samples, combine each key's trials, compute the parameters
    fits = {t.name: fit_period(t.rate, sample_rate_hz=t.sample_rate) for t in session.trials}
    for r in result.trials:
        assert r.result.fit.period == fits[r.trial_id].period
        assert r.result.fit.period_sigma == fits[r.trial_id].period_sigma
        assert r.options_from == "default"
    periods = {}
    for m in session.plan:
        c = combine_periods([fits[t.name] for t in session.trials_of(m.key)])
        periods[m.key] = (c.value, c.sigma)
    core = compute_parameters(session.measurements(periods))
    ours = result.parameters
    assert ours is not None
    assert list(ours.parameters.names) == list(core.parameters.names)
    for got, want in (
        (ours.parameters.values, core.parameters.values),
        (ours.parameters.sigmas, core.parameters.sigmas),
        (ours.parameters.covariance, core.parameters.covariance),
    ):
        assert relative_difference(got, want)[0] <= 1e-12
    ms = canonical_with_sigma(core)
    speeds = critical_speeds(ms.matrices, ms.g)
    assert result.stability is not None and result.stability.weave is not None
    assert result.stability.capsize is not None and speeds.weave is not None and speeds.capsize is not None
    assert relative_difference(result.stability.weave.speed, speeds.weave)[0] <= 1e-12
    assert relative_difference(result.stability.capsize.speed, speeds.capsize)[0] <= 1e-12
    assert not result.live.differences  # nothing recorded to compare with


def test_replay_reproduces_the_recorded_live_results(live_bag: Path) -> None:
    result = replay_bag(live_bag)
    assert {t.options_from for t in result.trials} == {"recorded"}
    assert all(json.loads(t.result.fit_options_json)["window"]["lead_in_s"] == 1.5 for t in result.trials)
    live = result.live
    assert live.compared_trials == len(result.trials) and not live.missing
    compared = {d.what for d in live.differences}
    assert {
        "combined periods",
        "parameters",
        "parameter covariance",
        "canonical matrices",
        "weave speed",
        "capsize speed",
        "eigenvalues",
    } <= compared
    assert live.identical, live.worst
    code, out, err = run_cli("replay", str(live_bag))
    assert (code, err) == (0, "")
    assert "live results: identical" in out


def test_other_fit_settings_are_used_and_reported_as_different(live_bag: Path) -> None:
    settings = ReplaySettings(fit=FitOverrides(window=WindowPolicy.lead_in(3.0)))
    result = replay_bag(live_bag, settings)
    assert {t.options_from for t in result.trials} == {"override"}
    assert all(t.result.fit.window_policy.lead_in_s == 3.0 for t in result.trials)
    assert not result.live.identical
    # how much it matters, in units of the live σ: each trial's period, and the results
    # (with a 3 s lead-in some keys lose every trial: only the trials compare)
    assert not result.complete and result.live.largest_move(trials=False) is None
    result = replay_bag(live_bag, ReplaySettings(fit=FitOverrides(window=WindowPolicy.lead_in(2.0))))
    assert result.complete and not result.live.identical
    moved = [
        abs(t.result.fit.period - t.recorded.fit.period) / t.recorded.fit.period_sigma
        for t in result.trials
        if t.recorded is not None
    ]
    trial = result.live.largest_move(trials=True)
    assert trial is not None and trial.in_sigma == pytest.approx(max(moved), rel=1e-12) and trial.in_sigma > 0
    results = result.live.largest_move(trials=False)
    assert results is not None and results.what in {"combined periods", "parameters", "weave speed", "capsize speed"}
    assert result.live.largest_in_sigma == max(trial.in_sigma, results.in_sigma)
    code, out, _ = run_cli("replay", str(live_bag), "--lead-in", "2", "--min-r2", "0.95")
    assert code == 0
    assert "live results: DIFFER" in out and "(expected: the fit settings are overridden)" in out
    assert "; moved, in units of the live σ: the results (combined periods, parameters, speeds) by at most " in out
    data = json.loads(run_cli("replay", str(live_bag), "--default-fit", "--json")[1])
    assert {t["fit_options"]["window"]["lead_in_s"] for t in data["trials"]} == {1.0}
    assert data["settings"]["fit_overridden"] and not data["live"]["identical"]
    assert data["live"]["largest_in_sigma"] > 0


def test_json_output(session: SimulatedSession, live_bag: Path) -> None:
    code, out, err = run_cli("replay", str(live_bag), "--json")
    assert (code, err) == (0, "")
    data = json.loads(out)
    assert data["bicycle"] == "Browser"
    assert set(data["parameters"]) == set(PARAMETER_NAMES)
    assert all(set(v) == {"value", "sigma"} for v in data["parameters"].values())
    assert isinstance(data["weave_speed"], float) and isinstance(data["capsize_speed"], float)
    assert [t["trial_id"] for t in data["trials"]] == [t.name for t in session.trials]
    assert all(t["used"] and t["period"] == t["live_period"] for t in data["trials"])
    assert data["live"]["identical"] and data["complete"] and data["missing"] == []
    code, out, _ = run_cli("replay", str(live_bag), "--rider", "paper", "--json")
    with_rider = json.loads(out)
    assert with_rider["settings"]["rider"] == "paper" and with_rider["weave_speed"] != data["weave_speed"]
    assert with_rider["parameters"] == data["parameters"]


def test_an_incomplete_session_exits_1(session: SimulatedSession, tmp_path: Path) -> None:
    dropped = {t.name for t in session.trials_of("TtB2")}
    messages = [
        m
        for m in simulated_messages(session, pause_s=2.0)
        if m.topic == STATIC_READINGS.name or str(m.message.trial_id) not in dropped
    ]
    bag = tmp_path / "incomplete"
    from bike_rig.bag.typestore import rig_typestore
    from bike_rig.bag.writer import BagWriter, contract_qos
    from bike_rig.config.topics import TOPICS

    with BagWriter(bag) as w:
        for t in TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for m in messages:
            w.write(m.topic, m.log_time, bytes(rig_typestore().serialize_cdr(m.message, m.message.__msgtype__)))
    result = replay_bag(bag)
    assert not result.complete and result.session.missing == ("TtB2",) and result.parameters is None
    code, out, _ = run_cli("replay", str(bag))
    assert code == 1 and "incomplete: no usable trial for TtB2" in out


def test_bad_input_is_one_line(session: SimulatedSession, tmp_path: Path) -> None:
    no_static = [m for m in simulated_messages(session, pause_s=2.0) if m.topic != STATIC_READINGS.name][:50]
    from bike_rig.bag.typestore import rig_typestore
    from bike_rig.bag.writer import BagWriter

    bag = tmp_path / "no_static"
    with BagWriter(bag) as w:
        for topic, msgtype in ((GYRO.name, GYRO.type), (TRIAL_EVENTS.name, TRIAL_EVENTS.type)):
            w.add_topic(topic, msgtype)
        for m in no_static:
            w.write(m.topic, m.log_time, bytes(rig_typestore().serialize_cdr(m.message, m.message.__msgtype__)))
    with pytest.raises(ReplayError, match="no StaticReadings message"):
        replay_bag(bag)
    other = tmp_path / "other"
    with BagWriter(other) as w:
        w.add_topic("/chatter", "std_msgs/msg/String")
    with pytest.raises(NoRigTopicsError):
        replay_bag(other)
    (tmp_path / "file.txt").write_text("x")
    for path, reason in (
        (bag, "no StaticReadings message"),
        (other, "holds none of bike_rig's topics"),
        (tmp_path / "file.txt", "not a bag"),
        (tmp_path / "none", "no such file"),
    ):
        code, out, err = run_cli("replay", str(path))
        assert code == 2 and out == "" and err.count("\n") == 1
        assert err.startswith(f"bike-rig replay: error: {path}: ") and reason in err
    code, _, err = run_cli("replay", str(bag), "--lead-in", "1", "--envelope", "0.1")
    assert code == 2 and "choose one window" in err


def test_replay_runs_without_rclpy(live_bag: Path) -> None:
    code = (
        "import sys, json\n"
        "import rclpy_blocker\n"
        "from bike_rig.offline.replay import replay_bag, result_json\n"
        f"r = replay_bag({str(live_bag)!r})\n"
        "assert 'rclpy' not in sys.modules, sorted(m for m in sys.modules if 'rcl' in m)\n"
        "print(json.dumps(result_json(r)['live']['identical']))\n"
    )
    blocker = (
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name == 'rclpy' or name.startswith('rclpy.'):\n"
        "            raise ImportError('rclpy is not allowed in the offline replay')\n"
        "sys.meta_path.insert(0, Block())\n"
    )
    site = live_bag.parent / "site"
    site.mkdir(exist_ok=True)
    (site / "rclpy_blocker.py").write_text(blocker)
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=120,
        env={"PYTHONPATH": f"{REPO}:{site}", "PATH": "/usr/bin:/bin"},
        cwd=REPO,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "true"


def children_of(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (from /proc)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue  # (gone meanwhile)
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def test_in_sigma() -> None:
    assert in_sigma([1.0, 2.0, 3.0], [1.5, 2.0, 0.0], [0.25, 1.0, 0.0]) == 2.0  # (no σ: not counted)
    assert math.isnan(in_sigma([1.0], [2.0], [math.nan]))
    assert in_sigma([math.inf, 1.0], [0.0, 1.0], [1.0, 1.0]) == 0.0


def test_relative_difference() -> None:
    assert (
        relative_difference([1.0, math.nan], [1.0, math.nan]) == (0.0, -1)
        or relative_difference([1.0, math.nan], [1.0, math.nan])[0] == 0.0
    )
    assert relative_difference([1.0, 2.0], [1.0, 2.0 * (1 + 1e-13)])[0] == pytest.approx(1e-13, rel=1e-3)
    assert relative_difference([1.0], [math.nan])[0] == math.inf
    assert relative_difference(np.zeros(2), np.zeros(3))[0] == math.inf
    assert relative_difference([0.0], [-0.0])[0] == 0.0


_ = SimulatedMessage  # imported for readers of the fixtures' types
