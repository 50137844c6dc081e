"""Reading a bag with the mcap library gives exactly what rosbags' reader gives.

The messages in order, the gyro batches the numpy decoder reads and the recorded session;
a bag the library does not read as rosbags does is left to rosbags.
"""

from __future__ import annotations

import dataclasses
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.rosbag2 import Reader

from bike_rig.bag.gyro_cdr import gyro_batch
from bike_rig.bag.reader import BagReader, open_bag
from bike_rig.bag.simulated import SimulatedMessage, simulated_messages
from bike_rig.bag.typestore import rig_typestore
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config.topics import GYRO, TOPICS, TRIAL_EVENTS
from bike_rig.core.sim import SimulatedSession
from bike_rig.messages import sample_batch_from_msg
from bike_rig.offline.session import RecordedSession, read_session
from test.support.samples import gyro_message, make_message, sample_traffic, serialize

COUNTS = {t.name: n for t, n in zip(TOPICS, (60, 9, 5, 1, 2, 3, 1, 4), strict=True)}


def write(path: Path, traffic: list[tuple[str, int, bytes, Any]], **options: Any) -> Path:
    with BagWriter(path, **options) as w:
        for t in TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for k, (name, log_time, data, _) in enumerate(traffic):
            w.write(name, log_time, data, publish_time=log_time - 1000, sequence=k + 1)
    return path


def rosbags_messages(path: Path, topics: list[str] | None = None) -> list[tuple[str, int, bytes]]:
    with Reader(path) as reader:
        conns = [c for c in reader.connections if topics is None or c.topic in topics]
        return [(c.topic, t, bytes(d)) for c, t, d in reader.messages(connections=conns)]


def mcap_messages(path: Path, topics: list[str] | None = None) -> list[tuple[str, int, bytes]] | None:
    with open_bag(path) as b:
        found = b.records(list(b.topics) if topics is None else topics)
    return None if found is None else [(r.topic, r.log_time, bytes(r.data)) for r in found]


def shuffled_traffic() -> list[tuple[str, int, bytes, Any]]:
    """Sample traffic written out of log-time order, with repeated log times."""
    traffic = sample_traffic(COUNTS)
    rng = np.random.default_rng(3)
    order = rng.permutation(len(traffic))
    times = [traffic[0][1] + 1_000_000 * int(k // 3) for k in range(len(traffic))]
    return [(traffic[i][0], times[k], traffic[i][2], traffic[i][3]) for k, i in enumerate(order)]


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_messages_equal_rosbags(tmp_path: Path, compression: str) -> None:
    bag = write(tmp_path / "bag", shuffled_traffic(), compression=compression, chunk_size=2000)
    assert mcap_messages(bag) == rosbags_messages(bag)
    single = bag / "bag_0.mcap"
    assert mcap_messages(single) == rosbags_messages(single)
    for topics in ([GYRO.name], [TRIAL_EVENTS.name, GYRO.name], [t.name for t in TOPICS[2:]]):
        assert mcap_messages(bag, topics) == rosbags_messages(bag, topics)


def plain(batch: Any) -> dict[str, Any]:
    out = dataclasses.asdict(batch)
    for k in ("rates", "raw_volts"):
        out[k] = (out[k].dtype.str, out[k].tobytes())
    out["types"] = tuple(type(getattr(batch, f.name)).__name__ for f in dataclasses.fields(batch))
    return out


def test_gyro_batches_decode_as_rosbags_does() -> None:
    store = rig_typestore()
    shapes = [
        ("", "t1", 50, 0),
        ("gyro", "t1", 50, 0),
        ("gyro", "trial-é", 3, 3),
        ("", "", 0, 0),
        ("fr", "t1", 0, 2),
        ("abcdefghijklm", "t12345678901234567", 1, 0),
        ("g", "t", 7, 7),
    ]
    msgs = [gyro_message(f, t, n, m, k) for k, (f, t, n, m) in enumerate(shapes)]
    msgs += [make_message(GYRO.type, seed) for seed in range(20)]
    datas = [serialize(m) for m in msgs]
    expected = [sample_batch_from_msg(store.deserialize_cdr(d, GYRO.type)) for d in datas]
    got = [gyro_batch(d) for d in datas]
    assert [plain(b) for b in got] == [plain(b) for b in expected]


def test_unusual_gyro_batches_are_left_to_rosbags() -> None:
    good = serialize(gyro_message("gyro", "t1", 5, 0, 1))
    assert gyro_batch(good) is not None
    big_endian = b"\x00\x00" + good[2:]
    bad = [big_endian, good[:-8], good + b"\x00" * 4, good[:12] + struct.pack("<I", 200) + good[16:], good[:3]]
    for data in bad:
        assert gyro_batch(data) is None


def session_messages(session: SimulatedSession) -> list[SimulatedMessage]:
    """A simulated session with the oddities a recording may hold."""
    msgs = list(simulated_messages(session, pause_s=2.0))
    gyro = [i for i, m in enumerate(msgs) if m.topic == GYRO.name]
    events = [i for i, m in enumerate(msgs) if m.topic == TRIAL_EVENTS.name]
    odd = []
    for k in gyro[5:8]:  # re-sent batches
        odd.append(SimulatedMessage(GYRO.name, msgs[k].log_time + 3_000_000, msgs[k].message))
    stray = dataclasses.replace(msgs[gyro[9]].message, trial_id="")
    odd.append(SimulatedMessage(GYRO.name, msgs[gyro[9]].log_time + 1, stray))
    other = dataclasses.replace(msgs[gyro[12]].message, trial_id="never-announced")
    odd.append(SimulatedMessage(GYRO.name, msgs[gyro[12]].log_time, other))
    unknown = dataclasses.replace(msgs[events[2]].message, kind=7)
    odd.append(SimulatedMessage(TRIAL_EVENTS.name, msgs[events[2]].log_time, unknown))
    short = msgs[gyro[20]].message
    msgs[gyro[20]] = SimulatedMessage(
        GYRO.name, msgs[gyro[20]].log_time, dataclasses.replace(short, rates=short.rates[:7], raw_volts=short.rates[:7])
    )
    return sorted(msgs + odd, key=lambda m: m.log_time)


def session_dump(s: RecordedSession) -> Any:
    trials = {
        tid: (t.start, t.stop, [plain(b) for b in t.batches], [serialize(e) for e in t.estimates])
        for tid, t in s.trials.items()
    }
    return (
        s.path,
        s.topics,
        s.start_time,
        s.end_time,
        s.message_count,
        s.storage_files,
        list(s.trials),
        trials,
        s.static_readings and serialize(s.static_readings),
        s.stray_batches,
        [serialize(m) for m in (*s.parameters, *s.matrices, *s.eigen_sweeps)],
    )


def read_both(bag: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[RecordedSession, RecordedSession]:
    """The session read with the mcap library, and with rosbags' reader message by message."""
    with open_bag(bag) as b:
        assert b.records(list(b.topics)) is not None
    by_mcap = read_session(bag)
    monkeypatch.setattr(BagReader, "records", lambda self, topics: None)
    return by_mcap, read_session(bag)


def test_a_session_reads_as_message_by_message(
    session: SimulatedSession, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    store = rig_typestore()
    types = {t.name: t.type for t in TOPICS}
    traffic = [
        (m.topic, m.log_time, bytes(store.serialize_cdr(m.message, types[m.topic])), m)
        for m in session_messages(session)
    ]
    bag = write(tmp_path / "odd", traffic, chunk_size=50_000)
    by_mcap, by_rosbags = read_both(bag, monkeypatch)
    assert session_dump(by_mcap) == session_dump(by_rosbags)
    assert by_mcap.stray_batches == 1 and "never-announced" in by_mcap.trials


def test_the_sample_traffic_session_reads_as_message_by_message(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    bag = write(tmp_path / "sample", shuffled_traffic(), chunk_size=2500)
    by_mcap, by_rosbags = read_both(bag, monkeypatch)
    assert session_dump(by_mcap) == session_dump(by_rosbags)


def test_a_channel_rosbags_skips_leaves_the_bag_to_rosbags(tmp_path: Path) -> None:
    """A channel whose QoS differs from metadata.yaml's is not one of rosbags' connections."""
    bag = write(tmp_path / "bag", sample_traffic(COUNTS))
    meta = bag / "metadata.yaml"
    text = meta.read_text()
    assert "depth: 2000" in text
    meta.write_text(text.replace("depth: 2000", "depth: 1999", 1))
    expected = rosbags_messages(bag)
    assert {t for t, _, _ in expected} != set(COUNTS)
    got = mcap_messages(bag)
    assert got is None or got == expected
    with open_bag(bag) as b:
        assert [(m.topic, m.log_time, bytes(m.data)) for m in b.messages()] == expected
