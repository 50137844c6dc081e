"""The fast read path gives exactly what rosbags gives.

The index, the messages in order, the decoded gyro batches and the recorded session; anything
unusual is left to rosbags.
"""

from __future__ import annotations

import dataclasses
import shutil
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.rosbag2 import Reader

from bike_rig.bag import session as session_module
from bike_rig.bag.errors import BagReadError
from bike_rig.bag.fastread import Unusual, open_fast
from bike_rig.bag.gyro_cdr import GYRO_TYPE, decode_gyro, is_our_layout
from bike_rig.bag.msgtable import read_table
from bike_rig.bag.reader import BagReader, open_bag
from bike_rig.bag.session import RecordedSession, read_session
from bike_rig.bag.simulated import SimulatedMessage, simulated_messages
from bike_rig.bag.typestore import new_message, rig_typestore
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.core.sim import SimulatedSession
from bike_rig.messages import sample_batch_from_msg
from bike_rig.topics import GYRO, TOPICS, TRIAL_EVENTS
from test.bag.samples import make_message, sample_traffic, serialize

COUNTS = {t.name: n for t, n in zip(TOPICS, (60, 9, 5, 1, 2, 3, 1, 4), strict=True)}


def write(path: Path, traffic: list[tuple[str, int, bytes, Any]], **options: Any) -> Path:
    with BagWriter(path, **options) as w:
        for t in TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for k, (name, log_time, data, _) in enumerate(traffic):
            w.write(name, log_time, data, publish_time=log_time - 1000, sequence=k + 1)
    return path


def rosbags_messages(path: Path) -> list[tuple[str, int, bytes]]:
    with Reader(path) as reader:
        return [(c.topic, t, bytes(d)) for c, t, d in reader.messages()]


def fast_messages(path: Path) -> list[tuple[str, int, bytes]]:
    bag = open_fast(path)
    table = read_table(bag, [c.name for c in bag.connections])
    return [(table.topics[int(table.topic[i])], int(table.log_time[i]), table.data(i)) for i in range(len(table))]


def shuffled_traffic() -> list[tuple[str, int, bytes, Any]]:
    """Sample traffic written out of log-time order, with repeated log times."""
    traffic = sample_traffic(COUNTS)
    rng = np.random.default_rng(3)
    order = rng.permutation(len(traffic))
    times = [traffic[0][1] + 1_000_000 * int(k // 3) for k in range(len(traffic))]
    return [(traffic[i][0], times[k], traffic[i][2], traffic[i][3]) for k, i in enumerate(order)]


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_index_and_messages_equal_rosbags(tmp_path: Path, compression: str) -> None:
    bag = write(tmp_path / "bag", shuffled_traffic(), compression=compression, chunk_size=2000)
    fast = open_fast(bag)
    with Reader(bag) as reader:
        expected = [
            (c.topic, c.msgtype, c.msgcount, tuple(c.ext.offered_qos_profiles), c.digest) for c in reader.connections
        ]
        assert [(t.name, t.msgtype, t.count, t.qos, t.digest) for t in fast.connections] == expected
        assert (fast.start_time, fast.end_time, fast.message_count) == (
            reader.start_time,
            reader.end_time - 1,
            reader.message_count,
        )
    assert len(fast.storages[0].chunks) > 5
    assert fast_messages(bag) == rosbags_messages(bag)
    single = bag / "bag_0.mcap"
    assert fast_messages(single) == rosbags_messages(single)


def test_messages_of_some_topics_equal_rosbags(tmp_path: Path) -> None:
    bag = write(tmp_path / "bag", shuffled_traffic(), chunk_size=3000)
    with open_bag(bag) as b:
        for topics in ([GYRO.name], [TRIAL_EVENTS.name, GYRO.name], [t.name for t in TOPICS[2:]]):
            table = b.table(topics)
            assert table is not None
            got = [
                (table.topics[int(table.topic[i])], int(table.log_time[i]), table.data(i)) for i in range(len(table))
            ]
            assert got == [(m.topic, m.log_time, bytes(m.data)) for m in b.messages(topics)]


def gyro_message(frame_id: str, trial_id: str, n: int, m: int, seed: int) -> Any:
    rng = np.random.default_rng(seed)
    msg = new_message(GYRO_TYPE, trial_id=trial_id, first_index=seed * 50, sample_rate_hz=1000.0 + seed)
    msg.header.frame_id = frame_id
    msg.header.stamp.sec, msg.header.stamp.nanosec = 1_800_000_000 + seed, seed * 7919 % 1_000_000_000
    msg.rates = rng.normal(size=n)
    msg.raw_volts = rng.normal(size=m)
    return msg


def decode(datas: list[bytes]) -> list[Any]:
    """The batches of ``datas`` decoded by :func:`decode_gyro` (placed at odd offsets of one buffer)."""
    buf = bytearray(b"\x07")
    start, size = [], []
    for d in datas:
        start.append(len(buf))
        size.append(len(d))
        buf += d + b"\x00" * (len(d) % 5)
    arr = np.frombuffer(bytes(buf), dtype=np.uint8)
    return decode_gyro(arr, np.array(start, dtype=np.int64), np.array(size, dtype=np.int64)).batches()


def plain(batch: Any) -> dict[str, Any]:
    out = dataclasses.asdict(batch)
    for k in ("rates", "raw_volts"):
        out[k] = (out[k].dtype.str, out[k].tobytes())
    out["types"] = tuple(type(getattr(batch, f.name)).__name__ for f in dataclasses.fields(batch))
    return out


def test_gyro_batches_decode_as_rosbags_does() -> None:
    store = rig_typestore()
    assert is_our_layout(store.fielddefs)
    msgs = [
        gyro_message(f, t, n, m, k)
        for k, (f, t, n, m) in enumerate(
            [
                ("", "t1", 50, 0),
                ("gyro", "t1", 50, 0),
                ("gyro", "t1", 50, 0),
                ("gyro", "trial-é", 3, 3),
                ("", "", 0, 0),
                ("fr", "t1", 0, 2),
                ("gyro", "t1", 50, 0),
                ("abcdefghijklm", "t12345678901234567", 1, 0),
            ]
        )
    ]
    msgs += [make_message(GYRO_TYPE, seed) for seed in range(20)]
    datas = [serialize(m) for m in msgs]
    expected = [sample_batch_from_msg(store.deserialize_cdr(d, GYRO_TYPE)) for d in datas]
    got = decode(datas)
    assert [plain(b) for b in got] == [plain(b) for b in expected]
    assert not got[0].rates.flags.writeable


@pytest.mark.parametrize("long_runs", [True, False])
def test_runs_of_batches_and_batches_of_varying_size_decode_as_rosbags_does(long_runs: bool) -> None:
    """Runs of equal batches back to back, and batches of varying sizes: the numbers rosbags reads.

    (31 bytes of record head between records: runs are strided copies, the rest one gather.)
    """
    store = rig_typestore()
    rng = np.random.default_rng(7)
    varying = [int(x) for x in rng.integers(0, 9, 15)]
    sizes = [50] * 20 + varying + [50] * 12 if long_runs else varying
    msgs = [gyro_message("gyro", f"t{k // 9}", n, n if k % 2 else 0, k) for k, n in enumerate(sizes)]
    datas = [serialize(m) for m in msgs]
    buf, start = bytearray(b"\x05"), []
    for d in datas:
        buf += bytes(31)
        start.append(len(buf))
        buf += d
    columns = decode_gyro(np.frombuffer(bytes(buf), dtype=np.uint8), np.array(start), np.array([len(d) for d in datas]))
    expected = [sample_batch_from_msg(store.deserialize_cdr(d, GYRO_TYPE)) for d in datas]
    assert [plain(b) for b in columns.batches()] == [plain(b) for b in expected]


def test_unusual_gyro_batches_are_left_to_rosbags() -> None:
    good = serialize(gyro_message("gyro", "t1", 5, 0, 1))
    big_endian = b"\x00\x00" + good[2:]
    bad = [big_endian, good[:-8], good + b"\x00" * 4, good[:12] + struct.pack("<I", 200) + good[16:]]
    for data in bad:
        with pytest.raises(Unusual):
            decode([good, data])
    assert not is_our_layout({**rig_typestore().fielddefs, GYRO_TYPE: ((), [("header", (2, "std_msgs/msg/Header"))])})


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
    calls: list[bool] = []
    real = session_module._from_table

    def spy(empty: RecordedSession, table: Any, bag: BagReader) -> Any:
        got = real(empty, table, bag)
        calls.append(got is not None)
        return got

    monkeypatch.setattr(session_module, "_from_table", spy)
    fast = read_session(bag)
    assert calls == [True]
    monkeypatch.setattr(BagReader, "table", lambda self, topics: None)
    return fast, read_session(bag)


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
    fast, slow = read_both(bag, monkeypatch)
    assert session_dump(fast) == session_dump(slow)
    assert fast.stray_batches == 1 and "never-announced" in fast.trials


def test_the_sample_traffic_session_reads_as_message_by_message(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    bag = write(tmp_path / "sample", shuffled_traffic(), chunk_size=2500)
    fast, slow = read_both(bag, monkeypatch)
    assert session_dump(fast) == session_dump(slow)


def test_unusual_bags_are_read_by_rosbags(tmp_path: Path) -> None:
    bag = write(tmp_path / "bag", sample_traffic(COUNTS))
    expected = rosbags_messages(bag)
    # metadata YAML 1.1 and 1.2 would read differently: rosbags reads it
    risky = tmp_path / "risky"
    shutil.copytree(bag, risky)
    meta = risky / "metadata.yaml"
    meta.write_text(meta.read_text().replace("custom_data: null", "custom_data:\n    reviewed: yes"))
    with pytest.raises(Unusual):
        open_fast(risky)
    with open_bag(risky) as b:
        assert b.table([GYRO.name]) is None
        assert [(m.topic, m.log_time, bytes(m.data)) for m in b.messages()] == expected
    # a chunk that fails its checksum: rosbags reports it
    corrupt = tmp_path / "corrupt"
    shutil.copytree(bag, corrupt)
    data = corrupt / "bag_0.mcap"
    raw = bytearray(data.read_bytes())
    chunk = open_fast(corrupt).storages[0].chunks[0]
    raw[chunk.offset + 9 + 24] ^= 0xFF
    data.write_bytes(bytes(raw))
    with open_bag(corrupt) as b:
        assert b.table([GYRO.name]) is None
        with pytest.raises(BagReadError, match="corrupt data"):
            list(b.messages())
    with pytest.raises(BagReadError, match="corrupt data"):
        read_session(corrupt)


def test_a_channel_with_other_qos_is_skipped_as_rosbags_does(tmp_path: Path) -> None:
    bag = write(tmp_path / "bag", sample_traffic(COUNTS))
    meta = bag / "metadata.yaml"
    text = meta.read_text()
    assert "depth: 2000" in text
    meta.write_text(text.replace("depth: 2000", "depth: 1999", 1))
    got = fast_messages(bag)
    assert got == rosbags_messages(bag)
    assert {t for t, _, _ in got} != set(COUNTS)


def test_qos_profiles_parse_as_rosbags_does() -> None:
    from rosbags.rosbag2.metadata import parse_qos

    from bike_rig.bag.fastread import _qos

    base = {
        "history": "keep_last",
        "depth": 10,
        "reliability": "reliable",
        "durability": "transient_local",
        "deadline": {"sec": 0, "nsec": 5},
        "lifespan": {"sec": 1, "nsec": 0},
        "liveliness": "system_default",
        "liveliness_lease_duration": {"sec": 2, "nsec": 3},
        "avoid_ros_namespace_conventions": False,
    }
    variants = [base, {**base, "history": 1, "reliability": 2, "durability": 99}, {**base, "liveliness": "nonsense"}]
    variants += [{**base, "history": "KEEP_ALL", "durability": "Volatile", "avoid_ros_namespace_conventions": True}]
    for profiles in ([], variants, *([v] for v in variants)):
        assert _qos(profiles) == tuple(parse_qos(profiles))  # type: ignore[arg-type]
    zero = "{sec: 0, nsec: 0}"
    pairs = [("history", "keep_last"), ("depth", 5), ("reliability", "best_effort"), ("durability", "volatile"),
             ("deadline", zero), ("lifespan", zero), ("liveliness", "automatic"),
             ("liveliness_lease_duration", zero), ("avoid_ros_namespace_conventions", "false")]  # fmt: skip
    text = "\n".join(("- " if i == 0 else "  ") + f"{k}: {v}" for i, (k, v) in enumerate(pairs))
    assert _qos(text) == tuple(parse_qos(text))


def test_messages_a_chunk_index_leaves_out_are_found() -> None:
    """The records between indexed messages are walked: a message the index does not list is kept, in file order."""
    from bike_rig.bag.fastread import Chunk
    from bike_rig.bag.msgtable import _keys_of_chunks, _Read

    def message(channel: int, log_time: int, data: bytes) -> bytes:
        sequence = log_time // 10
        return b"\x05" + struct.pack("<QHIQQ", 2 + 4 + 8 + 8 + len(data), channel, sequence, log_time, log_time) + data

    def index(channel: int, entries: list[tuple[int, int]]) -> bytes:
        pairs = b"".join(struct.pack("<QQ", t, o) for t, o in entries)
        return b"\x07" + struct.pack("<QHI", 6 + len(pairs), channel, len(pairs)) + pairs

    other = b"\x03" + struct.pack("<Q", 4) + b"abcd"  # a schema record before the messages
    m1, m2, m3 = message(1, 10, b"one"), message(1, 20, b"two!"), message(2, 30, b"three")
    records_a = other + m1 + m2
    records_b = m3
    chunk_a = Chunk(10, 20, 1000, 0, {}, 0, "", 0, len(records_a), {})
    chunk_b = Chunk(30, 30, 2000, 0, {}, 0, "", 0, len(records_b), {})
    reads = [  # chunk a's index lists only its second message
        _Read(chunk_a, memoryview(b""), 0, memoryview(index(1, [(20, len(other) + len(m1))]))),
        _Read(chunk_b, memoryview(b""), 0, memoryview(index(2, [(30, 0)]))),
    ]
    buffer = np.frombuffer(records_a + records_b, dtype=np.uint8)
    lut = np.full(65536, -1, dtype=np.int64)
    lut[1], lut[2] = 0, 1
    log_time, where, position, topic, start, size, sequence = _keys_of_chunks(buffer, reads, [0, len(records_a)], lut)
    assert log_time.tolist() == [10, 20, 30] and where.tolist() == [1000, 1000, 2000]
    assert sequence.tolist() == [1, 2, 3]
    assert position.tolist() == [0, 1, 0] and topic.tolist() == [0, 0, 1]
    assert [bytes(buffer[a : a + n]) for a, n in zip(start.tolist(), size.tolist(), strict=True)] == [
        b"one", b"two!", b"three"
    ]
