"""The recorder's controls as real processes over DDS: pause, resume, split, snapshot, split by size.

A publisher process (the rig's stand-in, gyro batches numbered by ``first_index``), the recorder
process, and the test's own node calling the recorder's services. What was recorded is checked
against what was published, by number: a pause drops exactly the batches published while paused
(and says how many), a split loses none, a snapshot holds the last seconds.
"""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path
from typing import Any

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from bike_rig.bag.reader import open_bag
from bike_rig.bag.recover import recover_bag, scan_mcap
from bike_rig.config.topics import (
    GYRO,
    RECORDER_PAUSE,
    RECORDER_RESUME,
    RECORDER_SNAPSHOT,
    RECORDER_SPLIT,
    STATIC_READINGS,
)
from bike_rig.offline.info import summarize
from test.support.nodes import node_environment
from test.support.probe import STEP_TIMEOUT_S, Probe
from test.support.processes import RosProcess
from test.support.recorder import start_publisher, start_recorder
from test.support.wait import wait_until

pytestmark = pytest.mark.ros

msgs: Any = pytest.importorskip("bike_rig_msgs.msg")
srvs: Any = pytest.importorskip("bike_rig_msgs.srv")


def _recorded_indexes(bag: Path) -> list[list[int]]:
    """The gyro batches' ``first_index`` in each storage file on disk now (a file being written too)."""
    from bike_rig.bag.typestore import rig_typestore

    store = rig_typestore()
    out = []
    for f in sorted(bag.glob("*.mcap"), key=lambda p: int(p.stem.rpartition("_")[2])):
        scan = scan_mcap(f)
        gyro = {cid for cid, ch in scan.channels.items() if ch.topic == GYRO.name}
        out.append(
            [store.deserialize_cdr(m.data, GYRO.type).first_index for m in scan.messages if m.channel_id in gyro]
        )
    return out


def _wait_recorded(probe: Probe, bag: Path, last_index: int, rec: RosProcess) -> None:
    """Wait until the recorder's flushed chunks hold the gyro batch ``last_index``."""

    def done() -> bool:
        assert rec.proc.poll() is None, rec.describe()
        return any(last_index in f for f in _recorded_indexes(bag))

    probe.spin_until(done, 30.0, f"gyro batch {last_index} in {bag}", rec.describe)


def _more(probe: Probe, seen: list[Any], n: int) -> None:
    """Wait until the test's own subscription has seen ``n`` more gyro batches."""
    goal = len(seen) + n
    probe.spin_until(lambda: len(seen) >= goal, STEP_TIMEOUT_S, f"{n} more gyro batches")


def test_pause_resume_split_and_snapshot_of_a_live_recording(
    ros_env: dict[str, str], tmp_path: Path, probe: Probe
) -> None:
    env = node_environment(ros_env)
    bag = tmp_path / "session"
    spec = {"early": {STATIC_READINGS.name: 1}, "live": {GYRO.name: 0}, "rate_hz": 200.0, "until_stop": True}
    clients = {
        name: probe.node.create_client(kind, name)
        for name, kind in (
            (RECORDER_PAUSE, srvs.Pause),
            (RECORDER_RESUME, srvs.Resume),
            (RECORDER_SPLIT, srvs.SplitBag),
            (RECORDER_SNAPSHOT, srvs.SaveSnapshot),
        )
    }
    with start_publisher(tmp_path, env, spec) as pub:
        pub.expect("EARLY", STEP_TIMEOUT_S)
        with start_recorder(tmp_path, env, bag, "topics:=[gyro, static_readings]", "snapshot_duration:=1.5") as rec:
            pub.expect("MATCHED", STEP_TIMEOUT_S)
            seen = probe.subscribe(GYRO, msgs.GyroBatch)
            pub.send("GO")
            _more(probe, seen, 100)
            paused = probe.call(clients[RECORDER_PAUSE], srvs.Pause.Request())
            assert (paused.ok, paused.message) == (True, "paused")
            assert probe.call(clients[RECORDER_PAUSE], srvs.Pause.Request()).message == "already paused"
            _more(probe, seen, 100)
            resumed = probe.call(clients[RECORDER_RESUME], srvs.Resume.Request())
            assert resumed.ok and resumed.message.startswith("resumed (")
            _more(probe, seen, 100)
            split = probe.call(clients[RECORDER_SPLIT], srvs.SplitBag.Request())
            assert (split.ok, split.closed_file, split.new_file) == (True, "session_0.mcap", "session_1.mcap")
            _more(probe, seen, 400)  # 2 s: more than the snapshot buffer holds
            snap = probe.call(clients[RECORDER_SNAPSHOT], srvs.SaveSnapshot.Request(seconds=1.0))
            assert snap.ok and snap.path == str(tmp_path / "session_snapshot_1"), snap.message
            all_snap = probe.call(
                clients[RECORDER_SNAPSHOT], srvs.SaveSnapshot.Request(output=str(tmp_path / "whole_buffer"))
            )
            assert all_snap.ok, all_snap.message
            again = probe.call(
                clients[RECORDER_SNAPSHOT], srvs.SaveSnapshot.Request(output=str(tmp_path / "whole_buffer"))
            )
            assert not again.ok and again.path == "" and "exists already" in again.message
            pub.send("STOP")
            published = json.loads(pub.expect("PUBLISHED", STEP_TIMEOUT_S))
            n = published["counts"][GYRO.name]
            _wait_recorded(probe, bag, n - 1, rec)
            assert rec.stop() == 0, rec.describe()
    log = rec.stderr_path.read_text()
    assert "split: closed session_0.mcap, recording into session_1.mcap" in log
    main = _check_pause_and_split(bag, log, n)
    _check_snapshots(snap, all_snap, main)


def _check_pause_and_split(bag: Path, log: str, n: int) -> dict[int, bytes]:
    """The recording holds the n gyro batches published less those published while paused, across the split.

    Returns:
        Its gyro batches' bytes by log time.
    """
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["relative_file_paths"] == ["session_0.mcap", "session_1.mcap"]
    dropped = int(meta["custom_data"]["messages_dropped_while_paused"])
    # (how many were published while paused the test cannot know exactly: its own subscription
    # sees them with its own delay; the gap below must have the size the recorder says)
    assert meta["custom_data"]["pauses"] == "1" and dropped > 0
    assert f"{dropped} message(s) arrived while paused (not recorded)" in log

    # what was published, less exactly the batches published while paused: one gap, of the count said
    files = _recorded_indexes(bag)
    recorded = [i for f in files for i in f]
    assert recorded == sorted(recorded) and recorded[0] == 0 and recorded[-1] == n - 1
    gaps = [(a, b) for a, b in zip(recorded, recorded[1:]) if b != a + 1]
    assert len(gaps) == 1 and gaps[0][1] - gaps[0][0] - 1 == dropped
    assert files[0][-1] + 1 == files[1][0]  # the split lost nothing
    assert len(files[1]) >= 400
    with open_bag(bag) as b:  # one session, as every reader sees it
        assert b.topics[GYRO.name].count == len(recorded) == meta["message_count"] - 1
        assert [m.first_index for _, _, m in b.decoded([GYRO.name])] == recorded
        main = {m.log_time: m.data for m in b.messages([GYRO.name])}
    assert [name for name, _ in summarize(bag).files] == ["session_0.mcap", "session_1.mcap"]
    return main


def _check_snapshots(snap: Any, all_snap: Any, main: dict[int, bytes]) -> None:
    # the snapshot: the second of log time up to the newest message at the call, the latched
    # static readings, bytes as recorded: exactly the recording's batches of that second (however
    # many a loaded machine delivered in it)
    with open_bag(snap.path) as s:
        assert s.topics[STATIC_READINGS.name].count == 1 and s.message_count == snap.message_count
        gyro = list(s.messages([GYRO.name]))
        indexes = [m.first_index for _, _, m in s.decoded([GYRO.name])]
    newest = gyro[-1].log_time
    assert [m.log_time for m in gyro] == sorted(t for t in main if newest - 1_000_000_000 <= t <= newest)
    assert len(gyro) >= 2 and newest - gyro[0].log_time <= 1_000_000_000
    assert indexes == list(range(indexes[0], indexes[0] + len(indexes)))
    assert all(main[m.log_time] == m.data for m in gyro)
    # the whole buffer: what the ring kept of snapshot_duration = 1.5 s. The ring evicts a message
    # whose log time is older than the newest pushed one's less 1.5 s (the static readings come
    # once, first, so the newest pushed is a gyro batch); its byte bound (64 MiB by default) is
    # far from reached by a few hundred ~100-byte batches. So it holds exactly the recording's
    # batches of [newest - 1.5 s, newest], however many a loaded machine delivered in it.
    with open_bag(all_snap.path) as s:
        assert s.topics[STATIC_READINGS.name].count == 1
        gyro_all = list(s.messages([GYRO.name]))
    newest = gyro_all[-1].log_time
    assert [m.log_time for m in gyro_all] == sorted(t for t in main if newest - 1_500_000_000 <= t <= newest)
    assert all(main[m.log_time] == m.data for m in gyro_all)
    # the snapshot before it, taken earlier, ends in the same buffer's window
    assert newest >= gyro[-1].log_time


def test_split_by_size_with_lz4_chunks_loses_nothing_and_opens_everywhere(
    ros_env: dict[str, str], tmp_path: Path, probe: Probe
) -> None:
    env = node_environment(ros_env)
    bag = tmp_path / "sized"
    spec = {"early": {STATIC_READINGS.name: 1}, "live": {GYRO.name: 600}, "rate_hz": 300.0}
    with start_publisher(tmp_path, env, spec) as pub:
        pub.expect("EARLY", STEP_TIMEOUT_S)
        with start_recorder(
            tmp_path, env, bag, "topics:=[gyro, static_readings]", "compression:=lz4", "max_bag_size:=25000"
        ) as rec:
            pub.expect("MATCHED", STEP_TIMEOUT_S)
            pub.send("GO")
            snapshots = probe.node.create_client(srvs.SaveSnapshot, RECORDER_SNAPSHOT)
            off = probe.call(snapshots, srvs.SaveSnapshot.Request(seconds=1.0))  # opt-in: off by default
            assert (off.ok, off.path) == (False, "")
            assert off.message == "snapshots are off (parameter snapshot_duration is 0)"
            published = json.loads(pub.expect("PUBLISHED", STEP_TIMEOUT_S))
            n = published["counts"][GYRO.name]
            deadline_probe = _FileWatcher(bag, n - 1, rec)
            deadline_probe.wait()
            assert rec.stop() == 0, rec.describe()
    assert "split (limit reached)" in rec.stderr_path.read_text()
    files = sorted(bag.glob("*.mcap"), key=lambda p: int(p.stem.rpartition("_")[2]))
    assert len(files) >= 3
    for f in files[:-1]:  # a closed file stays within the limit (as it is on disk) and is not left half empty
        assert 25000 / 2 < f.stat().st_size <= 25000, (f.name, f.stat().st_size)
    for f in files:
        with f.open("rb") as stream:  # mcap's own reader, each file alone: lz4 chunks, decodable
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            summary = reader.get_summary()
            assert summary is not None and {c.compression for c in summary.chunk_indexes} == {"lz4"}
            assert sum(1 for _ in reader.iter_decoded_messages()) == summary.statistics.message_count  # type: ignore[union-attr]
    with open_bag(bag) as b:
        assert [m.first_index for _, _, m in b.decoded([GYRO.name])] == list(range(n))
        assert b.topics[STATIC_READINGS.name].count == 1
        found = b.records([GYRO.name])
        assert found is not None and len(found) == n


class _FileWatcher:
    """Waits (polling the files, no ROS node) until the recorder's chunks hold a gyro batch."""

    def __init__(self, bag: Path, last_index: int, rec: RosProcess) -> None:
        self.bag, self.last_index, self.rec = bag, last_index, rec

    def wait(self, timeout_s: float = 30.0) -> None:
        def recorded() -> bool:
            assert self.rec.proc.poll() is None, self.rec.describe()
            return any(self.last_index in f for f in _recorded_indexes(self.bag))

        wait_until(recorded, f"gyro batch {self.last_index} recorded", timeout_s, 0.1, self.rec.describe)


def test_a_split_recording_killed_mid_file_is_recovered_as_one_gap_free_prefix(
    ros_env: dict[str, str], tmp_path: Path
) -> None:
    env = node_environment(ros_env)
    bag = tmp_path / "killed"
    spec = {"early": {STATIC_READINGS.name: 1}, "live": {GYRO.name: 0}, "rate_hz": 300.0, "until_stop": True}
    with start_publisher(tmp_path, env, spec) as pub:
        pub.expect("EARLY", STEP_TIMEOUT_S)
        with start_recorder(tmp_path, env, bag, "topics:=[gyro, static_readings]", "max_bag_size:=20000") as rec:
            pub.expect("MATCHED", STEP_TIMEOUT_S)
            pub.send("GO")
            _FileWatcher(bag, 700, rec).wait()  # several files closed, one being written
            os.killpg(rec.pid, signal.SIGKILL)
            assert rec.stop() == -signal.SIGKILL
        pub.send("STOP")
        pub.expect("PUBLISHED", STEP_TIMEOUT_S)
    assert not (bag / "metadata.yaml").exists() and len(list(bag.glob("*.mcap"))) >= 3
    on_disk = [i for f in _recorded_indexes(bag) for i in f]
    recovery = recover_bag(bag)
    assert [s.complete for s in recovery.files][:-1] == [True] * (len(recovery.files) - 1)
    with open_bag(recovery.output) as b:
        assert len(b.storage_files) == 1
        gyro = [m.first_index for _, _, m in b.decoded([GYRO.name])]
        assert b.topics[STATIC_READINGS.name].count == 1
    assert gyro == list(range(len(gyro))) == on_disk and len(gyro) > 700  # every flushed batch, no gap
