"""bike-rig bag info / recover: the session summary, the CLI text and JSON, bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from bike_rig.bag.errors import IncompleteBagError, NoRigTopicsError
from bike_rig.bag.simulated import RECORDED_TOPICS, SimulatedMessage, write_simulated_bag
from bike_rig.bag.typestore import new_message
from bike_rig.bag.writer import BagWriter
from bike_rig.config.topics import EIGEN_SWEEP, GYRO, PARAMETERS, PERIODS, TRIAL_EVENTS
from bike_rig.core.sim import SimulatedSession
from bike_rig.offline.info import summarize
from test.support.cli import run_cli

NS = 1_000_000_000


def estimate(
    trial_id: str, key: str, log_time: int, period: float, valid: bool = True, flags: tuple[str, ...] = ()
) -> SimulatedMessage:
    msg = new_message(
        PERIODS.type,
        trial_id=trial_id,
        measurement_key=key,
        period=period,
        period_sigma=1e-4,
        valid=valid,
        flags=list(flags),
        flag_reasons=["why"] * len(flags),
    )
    return SimulatedMessage(PERIODS.name, log_time, msg)


@pytest.fixture(scope="module")
def info_bag(session: SimulatedSession, tmp_path_factory: pytest.TempPathFactory) -> Path:
    end = 1_800_000_000 * NS + 3600 * NS
    t1, t2, t3 = session.trials[:3]
    extra = [
        estimate(t1.name, t1.key, end, 1.4),
        estimate(t2.name, t2.key, end + 1, 1.5, flags=("beating",)),
        estimate(t3.name, t3.key, end + 2, math.nan, valid=False, flags=("no_oscillation",)),
        SimulatedMessage(
            PARAMETERS.name,
            end + 3,
            new_message(PARAMETERS.type, bicycle=session.bicycle, missing=["TcR1", "TtB1"], com_method="centroid"),
        ),
        SimulatedMessage(
            EIGEN_SWEEP.name,
            end + 4,
            new_message(EIGEN_SWEEP.type, has_weave=True, weave_speed=4.2, has_capsize=False, weave_speed_sigma=0.1),
        ),
    ]
    return write_simulated_bag(tmp_path_factory.mktemp("info") / "session", session, extra=extra, pause_s=2.0)


def test_summary_of_a_session(session: SimulatedSession, info_bag: Path) -> None:
    s = summarize(info_bag)
    assert s.bicycle == "Browser"
    assert s.static_readings == len(session.readings)
    assert [t.trial_id for t in s.trials] == [t.name for t in session.trials]
    assert [t.measurement_key for t in s.trials] == [t.key for t in session.trials]
    n = session.trials[0].rate.size
    assert all(t.samples == t.announced == n and t.state == "complete" for t in s.trials)
    assert all(t.batches == math.ceil(n / 50) for t in s.trials)
    assert [(t.valid, t.usable, t.flags) for t in s.trials[:4]] == [
        (True, True, ()),
        (True, False, ("beating",)),
        (False, False, ("no_oscillation",)),
        (None, None, ()),
    ]
    counts = {t.name: t.count for t in s.topics}
    assert counts[GYRO.name] == len(session.trials) * math.ceil(n / 50)
    assert counts[TRIAL_EVENTS.name] == 2 * len(session.trials)
    assert set(counts) == {t.name for t in RECORDED_TOPICS}
    assert s.live.parameter_sets == 1 and not s.live.complete and s.live.missing == ("TcR1", "TtB1")
    assert (s.live.weave_speed, s.live.capsize_speed) == (4.2, None)
    assert s.duration_s == pytest.approx((s.end_ns - s.start_ns) / 1e9)


def test_info_command_text_and_json(session: SimulatedSession, info_bag: Path) -> None:
    code, out, err = run_cli("bag", "info", str(info_bag))
    assert (code, err) == (0, "")
    assert "bicycle:    Browser" in out
    assert f"trials:     {len(session.trials)} for 13 measurement keys; period estimates: 1 valid, 2 flagged" in out
    first = session.trials[0]
    row = next(line for line in out.splitlines() if line.startswith(first.name + " "))
    assert first.key in row and "complete" in row and f"{first.rate.size}" in row and row.endswith("valid")
    assert "flagged: beating" in out and "invalid: no_oscillation" in out
    assert "parameter set incomplete, missing TcR1, TtB1; weave 4.2000 m/s, capsize none" in out
    code, out, _ = run_cli("bag", "info", str(info_bag), "--json")
    data = json.loads(out)
    assert data["bicycle"] == "Browser" and len(data["trials"]) == len(session.trials)
    assert data["trials"][2]["period"] is None  # NaN as null


def test_info_errors_are_one_line(tmp_path: Path) -> None:
    other = tmp_path / "other"
    with BagWriter(other) as w:
        w.add_topic("/chatter", "std_msgs/msg/String")
        w.write("/chatter", 1, b"\x00\x01\x00\x00\x03\x00\x00\x00hi\x00\x00")
    with pytest.raises(NoRigTopicsError, match="holds none of bike_rig's topics"):
        summarize(other)
    crashed = tmp_path / "crashed"
    w = BagWriter(crashed)
    w.open()
    w.abort()
    with pytest.raises(IncompleteBagError):
        summarize(crashed)
    for bag, reason in (
        (other, "holds none of bike_rig's topics"),
        (crashed, "did not end cleanly"),
        (tmp_path / "nothing", "no such file or directory"),
    ):
        code, out, err = run_cli("bag", "info", str(bag))
        assert code == 2 and out == ""
        assert err.startswith(f"bike-rig bag: error: {bag}: ") and reason in err and err.count("\n") == 1


def test_recover_command_reports_per_topic(session: SimulatedSession, info_bag: Path, tmp_path: Path) -> None:
    data = (info_bag / "session_0.mcap").read_bytes()
    cut = tmp_path / "cut"
    cut.mkdir()
    (cut / "cut_0.mcap").write_bytes(data[: len(data) // 2])
    code, out, err = run_cli("bag", "recover", str(cut))
    assert code == 0, err
    total = summarize(info_bag).message_count
    recovered = int(out.split()[1])
    assert 0 < recovered < total
    assert f"recovered {recovered} messages from {cut} into {tmp_path / 'cut_recovered'}" in out
    assert "cut after byte" in out
    rows = {line.split()[0]: int(line.split()[1]) for line in out.splitlines() if line.startswith("/bike_rig/")}
    assert sum(rows.values()) == recovered and rows["/bike_rig/static_readings"] == 1
    head = tmp_path / "head"
    head.mkdir()
    (head / "head_0.mcap").write_bytes(data[:100])
    code, out, err = run_cli("bag", "recover", str(head))
    assert code == 2 and "nothing to recover" in err and err.count("\n") == 1
    code, out, err = run_cli("bag", "recover", str(info_bag), "-o", str(tmp_path / "copy"), "--json")
    assert code == 0, err
    report = json.loads(out)
    assert report["was_complete"] and report["message_count"] == summarize(info_bag).message_count
    code, out, err = run_cli("bag", "recover", str(info_bag), "-o", str(tmp_path / "copy"))
    assert code == 2 and "exists already" in err


def test_a_ros1_bag_is_refused_in_one_line_with_the_converter_named(tmp_path: Path) -> None:
    """A ROS 1 bag (which rosbags reads): bike-rig says it reads ROS 2 bags and how to convert one."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    path = tmp_path / "old.bag"
    with Writer(path) as w:
        conn = w.add_connection("/chatter", "std_msgs/msg/String", typestore=store)
        w.write(conn, 1_000, store.serialize_ros1(store.types["std_msgs/msg/String"](data="hi"), "std_msgs/msg/String"))
    code, out, err = run_cli("bag", "info", str(path))
    assert code == 2 and not out
    assert err.count("\n") == 1 and "a ROS 1 bag" in err and "rosbags-convert" in err, err
