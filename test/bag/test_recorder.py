"""The recorder as a real process over DDS.

A publisher process (the rig's stand-in) and the recorder, both with the run's domain id on
loopback; the bag is checked with rosbags.
"""

from __future__ import annotations

import json
import os
import signal
import time
from pathlib import Path
from typing import Any

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from bike_rig.bag.reader import open_bag
from bike_rig.bag.recover import recover_bag, scan_mcap
from bike_rig.config.topics import (
    EIGEN_SWEEP,
    GYRO,
    MATRICES,
    PARAMETERS,
    PERIODS,
    READINGS,
    STATIC_READINGS,
    TOPICS,
    TRIAL_EVENTS,
)
from test.support.nodes import node_environment
from test.support.probe import STEP_TIMEOUT_S
from test.support.recorder import start_publisher, start_recorder, wait_for_data
from test.support.samples import as_plain, make_message, seed_of
from test.support.wait import wait_until

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parents[2]
TYPES = {t.name: t.type for t in TOPICS}


def test_recorder_records_every_topic_exactly_and_in_order(ros_env: dict[str, str], tmp_path: Path) -> None:
    env = node_environment(ros_env)
    bag = tmp_path / "session"
    early = {STATIC_READINGS.name: 1, PERIODS.name: 3, READINGS.name: 2}  # transient-local, before the recorder starts
    live = {
        GYRO.name: 400,
        TRIAL_EVENTS.name: 6,
        PERIODS.name: 4,
        PARAMETERS.name: 1,
        MATRICES.name: 1,
        EIGEN_SWEEP.name: 1,
    }
    spec = {"early": early, "live": live, "rate_hz": 200.0}  # 200 gyro batches/s: the 10 kHz stress rate
    expected = {name: early.get(name, 0) + live.get(name, 0) for name in TYPES}
    with start_publisher(tmp_path, env, spec) as pub:
        pub.expect("EARLY", STEP_TIMEOUT_S)
        with start_recorder(tmp_path, env, bag) as rec:
            pub.expect("MATCHED", STEP_TIMEOUT_S)
            pub.send("GO")
            published = json.loads(pub.expect("PUBLISHED", STEP_TIMEOUT_S))
            wait_for_data(bag, expected, rec)
            code = rec.stop()
        assert code == 0, rec.describe()
        assert "closed" in rec.stderr_path.read_text()
    assert published["counts"] == expected

    with open_bag(bag) as b:
        counts = {n: t.count for n, t in b.topics.items()}
        # every topic of the graph: the recorder's own /diagnostics too, and the fitter's details (none here)
        assert counts.pop("/diagnostics") >= 1 and counts.pop("/bike_rig/fit_details") == 0
        assert counts == expected
        by_topic: dict[str, list[tuple[int, Any]]] = {n: [] for n in TYPES}
        for name, log_time, msg in b.decoded(list(TYPES)):
            by_topic[name].append((log_time, msg))
        raw = list(b.messages([GYRO.name]))
    for name, got in by_topic.items():
        want = [as_plain(make_message(TYPES[name], seed_of(name, k))) for k in range(expected[name])]
        plain = [as_plain(m) for _, m in got]
        if name == GYRO.name:  # the publisher sets first_index and the stamp
            assert [p["first_index"] for p in plain] == list(range(expected[name]))
            stamps = [p["header"]["stamp"]["sec"] * 10**9 + p["header"]["stamp"]["nanosec"] for p in plain]
            assert stamps == published["gyro_stamps"]
            # log time = receive time: after the publisher stamped it
            assert all(lt >= st for (lt, _), st in zip(got, stamps))
            for p, w in zip(plain, want):
                p.pop("header"), w.pop("header"), p.pop("first_index"), w.pop("first_index")
        assert plain == want, name  # content intact and in publication order
    assert all(len(m.data) > 4 and m.data[:2] == b"\x00\x01" for m in raw)  # CDR LE encapsulation

    # mcap's own reader decodes every message from the embedded ros2msg schemas
    with (bag / "session_0.mcap").open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        decoded: dict[str, int] = {}
        for schema, channel, _, _ in reader.iter_decoded_messages():
            assert (schema.encoding, channel.message_encoding) == ("ros2msg", "cdr")
            decoded[channel.topic] = decoded.get(channel.topic, 0) + 1
    assert decoded.pop("/diagnostics") >= 1  # (what Foxglove's diagnostics panel shows of a bag)
    assert decoded == {k: v for k, v in expected.items() if v}

    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    qos = {
        t["topic_metadata"]["name"]: t["topic_metadata"]["offered_qos_profiles"]
        for t in meta["topics_with_message_count"]
    }
    assert qos[STATIC_READINGS.name][0]["durability"] == "transient_local"
    assert qos[GYRO.name][0]["reliability"] == "reliable"


def test_recorder_refuses_to_overwrite_a_bag(ros_env: dict[str, str], tmp_path: Path) -> None:
    bag = tmp_path / "exists"
    bag.mkdir()
    with start_recorder(tmp_path, node_environment(ros_env), bag) as rec:
        code = rec.proc.wait(timeout=STEP_TIMEOUT_S)
    assert code == 2
    err = rec.stderr_path.read_text().strip().splitlines()
    assert err[-1] == f"recorder: error: {bag}: exists already; a bag is never overwritten (choose another output)"


def test_bag_of_a_killed_recorder_is_recovered_with_everything_it_had_flushed(
    ros_env: dict[str, str], tmp_path: Path
) -> None:
    env = node_environment(ros_env)
    bag = tmp_path / "killed"
    spec = {"early": {STATIC_READINGS.name: 1}, "live": {GYRO.name: 0}, "rate_hz": 200.0, "until_stop": True}
    with start_publisher(tmp_path, env, spec) as pub:
        pub.expect("EARLY", STEP_TIMEOUT_S)
        with start_recorder(tmp_path, env, bag, "topics:=[gyro, static_readings]") as rec:
            pub.expect("MATCHED", STEP_TIMEOUT_S)
            pub.send("GO")
            wait_for_data(bag, {GYRO.name: 300}, rec)
            # what is on disk just before the kill: the flushed chunks (the file only grows)
            scan = scan_mcap(bag / "killed_0.mcap")
            os.killpg(rec.pid, signal.SIGKILL)  # the recorder's own process group: timeout + python
            assert rec.stop() == -signal.SIGKILL
        pub.send("STOP")
        published = json.loads(pub.expect("PUBLISHED", STEP_TIMEOUT_S))
    assert not (bag / "metadata.yaml").exists()
    gyro_id = next(cid for cid, ch in scan.channels.items() if ch.topic == GYRO.name)
    flushed = [m.data for m in scan.messages if m.channel_id == gyro_id]
    assert len(flushed) >= 300

    recovery = recover_bag(bag)
    assert not recovery.was_complete
    counts = {t.name: t.count for t in recovery.topics}
    with open_bag(recovery.output) as b:
        assert {n: t.count for n, t in b.topics.items()} == counts
        gyro = [m for _, _, m in b.decoded([GYRO.name])]
        data = [m.data for m in b.messages([GYRO.name])]
    # a gap-free prefix of what was published ...
    assert [m.first_index for m in gyro] == list(range(len(gyro)))
    assert len(gyro) <= len(published["gyro_stamps"])
    assert counts[STATIC_READINGS.name] == 1
    # ... holding, byte for byte, everything the recorder had flushed before the kill
    assert data[: len(flushed)] == flushed, (len(data), len(flushed))


@pytest.mark.parametrize(
    ("param", "reason"),
    [
        ("topics:=[gyro, nope]", "parameter 'topics': unknown topic 'nope' (known: all, gyro, trial_events,"),
        ("compression:=gzip", "parameter 'compression' = 'gzip': expected one of zstd, lz4, none"),
        ("flush_period:=2.0", "parameter 'flush_period': must be within (0, 1]"),
    ],
)
def test_bad_parameters_end_in_one_line(ros_env: dict[str, str], tmp_path: Path, param: str, reason: str) -> None:
    bag = tmp_path / "bag"
    with start_recorder(tmp_path, node_environment(ros_env), bag, param) as rec:
        code = rec.proc.wait(timeout=STEP_TIMEOUT_S)
    assert code == 2
    assert rec.stderr_path.read_text().strip().splitlines()[-1].startswith(f"recorder: error: {reason}")
    assert not bag.exists()


@pytest.fixture
def small_disk(tmp_path: Path) -> Any:
    """A 256 kB tmpfs the test mounts (root is needed; CI and the developers' machines run as root)."""
    import subprocess

    mnt = tmp_path / "disk"
    mnt.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(mnt)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


def test_a_full_disk_stops_recording_in_one_line_keeps_the_bag_recoverable_and_the_node_up(
    ros_env: dict[str, str], tmp_path: Path, small_disk: Path
) -> None:
    env = node_environment(ros_env)
    bag = small_disk / "bag"
    spec = {"early": {STATIC_READINGS.name: 1}, "live": {GYRO.name: 0}, "rate_hz": 400.0, "until_stop": True}
    with start_publisher(tmp_path, env, spec) as pub:
        pub.expect("EARLY", STEP_TIMEOUT_S)
        with start_recorder(tmp_path, env, bag, "topics:=[gyro, static_readings]") as rec:
            pub.expect("MATCHED", STEP_TIMEOUT_S)
            pub.send("GO")

            def stopped() -> bool:
                assert rec.proc.poll() is None, rec.describe()
                return "recording stopped" in rec.stderr_path.read_text()

            wait_until(stopped, "the recorder to stop recording", 60, 0.1, rec.describe)
            time.sleep(1.0)  # the node stays up and keeps counting
            assert rec.proc.poll() is None, rec.describe()
            pub.send("STOP")
            pub.expect("PUBLISHED", STEP_TIMEOUT_S)
            code = rec.stop()
    log = rec.stderr_path.read_text()
    stopped = [line for line in log.splitlines() if "recording stopped: cannot write" in line]
    assert len(stopped) == 1, log[-3000:]  # said once
    assert "No space left on device" in stopped[0] and "bike-rig bag recover" in stopped[0]
    assert "not recorded after recording stopped" in log and "flush failed" not in log
    assert code == 1  # what it could not record is not hidden
    assert not (bag / "metadata.yaml").exists()
    recovery = recover_bag(bag, tmp_path / "recovered")
    with open_bag(recovery.output) as b:
        gyro = [m for _, _, m in b.decoded([GYRO.name])]
    assert len(gyro) > 100 and [m.first_index for m in gyro] == list(range(len(gyro)))  # a gap-free prefix
