"""Split bags (several storage files in one directory) and the snapshot buffer, in process.

A split bag is written as rosbag2 writes one (``NAME_0.mcap``, ``NAME_1.mcap``, ... each a
complete MCAP file; metadata.yaml lists them all) and must read as one session: by rosbags,
by bike_rig's reader with the mcap library, by mcap's own reader file by file, and by ``recover`` when its last
file was cut off.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader

from bike_rig.bag.reader import open_bag
from bike_rig.bag.recover import recover_bag, storage_files
from bike_rig.bag.snapshot import MESSAGE_OVERHEAD, BufferedMessage, SnapshotBuffer, SnapshotTopic, write_snapshot
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config.topics import GYRO, STATIC_READINGS, TOPICS
from test.support.samples import sample_traffic

COUNTS = {t.name: n for t, n in zip(TOPICS, (1500, 30, 20, 1, 2, 3, 1, 3))}
CHUNK = 16 << 10
TRAFFIC = sample_traffic(COUNTS)


def _write(path: Path, compression: str = "zstd", **split: float) -> BagWriter:
    with BagWriter(path, compression=compression, chunk_size=CHUNK, **split) as w:  # type: ignore[arg-type]
        for t in TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for k, (name, log_time, data, _) in enumerate(TRAFFIC):
            w.write(name, log_time, data, publish_time=log_time - 1000, sequence=k + 1)
    return w


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_split_by_size_keeps_every_message_in_order_and_every_file_opens_alone(
    tmp_path: Path, compression: str
) -> None:
    whole = _write(tmp_path / "whole", compression)
    limit = whole.bytes_written // 4  # about four files
    bag = tmp_path / "split"
    w = _write(bag, compression, max_bytes=limit)
    files = [bag / name for name in w.files]
    assert len(files) >= 4, w.files
    assert [f.name for f in files] == [f"split_{i}.mcap" for i in range(len(files))]
    assert sorted(p.name for p in bag.glob("*.mcap")) == sorted(f.name for f in files)
    for f in files[:-1]:  # within the limit on disk, closing records included, short of it by less than a chunk
        assert limit - CHUNK < f.stat().st_size <= limit, (f.name, f.stat().st_size, limit)

    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["relative_file_paths"] == [f.name for f in files]
    assert [e["path"] for e in meta["files"]] == [f.name for f in files]
    assert sum(e["message_count"] for e in meta["files"]) == meta["message_count"] == len(TRAFFIC)

    # mcap's own reader: each file complete, decodable, with the schemas and channels of its messages
    per_file = []
    for f in files:
        with f.open("rb") as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            summary = reader.get_summary()
            assert summary is not None and summary.statistics is not None
            assert {ci.compression for ci in summary.chunk_indexes} == {"" if compression == "none" else compression}
            decoded = reader.iter_decoded_messages(log_time_order=False)
            per_file.append([(ch.topic, m.log_time) for _, ch, m, _ in decoded])
            # the channels of the topics it holds messages of, no other (as the MCAP format's checks want)
            assert {c.topic for c in summary.channels.values()} == {topic for topic, _ in per_file[-1]}
    assert [len(p) for p in per_file] == [e["message_count"] for e in meta["files"]]
    expected = [(name, t, data) for name, t, data, _ in TRAFFIC]
    assert [x for p in per_file for x in p] == [(name, t) for name, t, _ in expected]

    # rosbags (the whole directory), and bike_rig's reader by both of its paths
    with Reader(bag) as reader:
        assert [(c.topic, t, bytes(d)) for c, t, d in reader.messages()] == expected
    with open_bag(bag) as b:
        assert {n: t.count for n, t in b.topics.items()} == COUNTS
        assert b.storage_files == files
        found = b.records(list(b.topics))
        assert found is not None  # the mcap library reads a split bag too
        assert [(r.topic, r.log_time) for r in found] == [(name, t) for name, t, _ in expected]
        assert [bytes(r.data) for r in found] == [d for *_, d in expected]
        assert [(m.topic, m.log_time, m.data) for m in b.messages()] == expected


@pytest.mark.parametrize("compression", ["zstd", "lz4"])
def test_a_file_stays_within_the_limit_when_its_last_chunk_compresses_worse(tmp_path: Path, compression: str) -> None:
    # well-compressing batches set the file's ratio; then data that does not compress at all
    # arrive in the chunk in progress (as model results after a session of gyro batches)
    rng = np.random.default_rng(5)
    limit = 120_000
    plain = bytes(4) + bytes(800)
    noise = [bytes(4) + rng.bytes(800) for _ in range(400)]
    bag = tmp_path / "mixed"
    with BagWriter(bag, compression=compression, chunk_size=1 << 20, flush_period_s=1e9, max_bytes=limit) as w:
        w.add_topic(GYRO.name, GYRO.type, offered_qos=[contract_qos(GYRO.qos)])
        for k in range(3000):
            w.write(GYRO.name, 10**9 + k * 10**6, noise[k % 400] if (k // 150) % 2 else plain)
    files = [bag / name for name in w.files]
    assert len(files) >= 3, w.files
    sizes = [f.stat().st_size for f in files]
    assert all(size <= limit for size in sizes), sizes
    assert all(size > limit // 2 for size in sizes[:-1]), sizes
    with Reader(bag) as reader:
        assert sum(1 for _ in reader.messages()) == 3000


def test_split_by_duration_bounds_each_files_span(tmp_path: Path) -> None:
    bag = tmp_path / "timed"
    w = _write(bag, max_duration_s=0.5)  # 1 ms between messages: 500 per file
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    spans = [e["duration"]["nanoseconds"] for e in meta["files"]]
    assert len(w.files) == -(-len(TRAFFIC) // 500)
    assert all(s < 500_000_000 for s in spans)
    assert [e["message_count"] for e in meta["files"]][:-1] == [500] * (len(spans) - 1)
    with open_bag(bag) as b:
        assert b.message_count == len(TRAFFIC) and b.duration == TRAFFIC[-1][1] - TRAFFIC[0][1]


def test_split_on_request_and_more_than_ten_files_keep_their_order(tmp_path: Path) -> None:
    bag = tmp_path / "many"
    with BagWriter(bag) as w:
        for t in TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for k, (name, log_time, data, _) in enumerate(TRAFFIC):
            if k and k % 120 == 0:
                closed, new = w.split()
                assert (closed, new) == (f"many_{k // 120 - 1}.mcap", f"many_{k // 120}.mcap")
            w.write(name, log_time, data)
    assert len(w.files) == -(-len(TRAFFIC) // 120) > 10
    assert [p.name for p in storage_files(bag)] == w.files  # many_2 before many_10
    with open_bag(bag) as b:
        assert [m.log_time for m in b.messages()] == [t for _, t, _, _ in TRAFFIC]
        assert [p.name for p in b.storage_files] == w.files


def test_a_split_bag_whose_last_file_stayed_empty_reads_by_the_mcap_library(tmp_path: Path) -> None:
    bag = tmp_path / "tail"
    with BagWriter(bag) as w:
        for t in TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for name, log_time, data, _ in TRAFFIC[:100]:
            w.write(name, log_time, data)
        w.split()  # a split_bag call just before the recording ended
    assert w.files == ["tail_0.mcap", "tail_1.mcap"]
    with open_bag(bag) as b:
        found = b.records(list(b.topics))
        assert found is not None and [bytes(r.data) for r in found] == [d for _, _, d, _ in TRAFFIC[:100]]
        assert [m.data for m in b.messages()] == [d for _, _, d, _ in TRAFFIC[:100]]


def test_recover_a_split_bag_whose_last_file_was_cut_off(tmp_path: Path) -> None:
    bag = tmp_path / "cut"
    w = _write(bag, max_bytes=_write(tmp_path / "whole").bytes_written // 4)
    files = [bag / name for name in w.files]
    # as a killed recorder leaves it: no metadata.yaml, the last file cut in its data section
    (bag / "metadata.yaml").unlink()
    last = files[-1]
    with last.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    chunk = summary.chunk_indexes[-1]
    last.write_bytes(last.read_bytes()[: chunk.chunk_start_offset + chunk.chunk_length // 2])  # in its last chunk
    meta_counts = []
    for f in files[:-1]:
        with f.open("rb") as stream:
            summary = make_reader(stream).get_summary()
            assert summary is not None and summary.statistics is not None
            meta_counts.append(summary.statistics.message_count)
    recovery = recover_bag(bag)
    assert not recovery.was_complete and [s.complete for s in recovery.files] == [True] * (len(files) - 1) + [False]
    assert sum(meta_counts) <= recovery.message_count < len(TRAFFIC)
    with open_bag(recovery.output) as b:
        got = [(m.topic, m.log_time, m.data) for m in b.messages()]
    assert got == [(name, t, data) for name, t, data, _ in TRAFFIC[: len(got)]]  # a gap-free prefix
    shutil.rmtree(recovery.output)


def _msg(topic: str, t_s: float, size: int = 100) -> BufferedMessage:
    return BufferedMessage(topic, int(t_s * 1e9), int(t_s * 1e9), 0, bytes(size))


def test_snapshot_buffer_keeps_the_last_seconds_within_its_bytes_and_the_latched_topics() -> None:
    buf = SnapshotBuffer(2.0, 100_000, latched=[STATIC_READINGS.name])
    buf.push(_msg(STATIC_READINGS.name, 0.0, 50))
    for k in range(100):  # 0.1 s apart, 10 s
        buf.push(_msg(GYRO.name, 0.1 * (k + 1)))
    times = [m.log_time for m in buf.window() if m.topic == GYRO.name]
    assert times[-1] == int(10.0 * 1e9) and times[0] >= int(8.0 * 1e9) and len(times) == 21
    assert buf.bytes == 21 * (100 + MESSAGE_OVERHEAD) and buf.evicted == 100 + 1 - 21
    assert buf.window()[0].topic == STATIC_READINGS.name  # latched: kept though 10 s old
    assert [m.log_time for m in buf.window(0.5)][1:] == [int(round(t * 1e9)) for t in (9.5, 9.6, 9.7, 9.8, 9.9, 10.0)]
    small = SnapshotBuffer(100.0, 3 * (300 + MESSAGE_OVERHEAD) + 10)
    for k in range(50):
        small.push(_msg(GYRO.name, k, 300))
    assert len(small) == 3 and small.bytes == 3 * (300 + MESSAGE_OVERHEAD)  # bounded in bytes before time
    with pytest.raises(ValueError, match="positive"):
        SnapshotBuffer(0.0, 10)
    with pytest.raises(ValueError, match="seconds"):
        small.window(-1.0)


def test_a_snapshot_bag_reads_back_its_messages(tmp_path: Path) -> None:
    buf = SnapshotBuffer(60.0, 1 << 20, latched=[STATIC_READINGS.name])
    for name, log_time, data, _ in TRAFFIC:
        buf.push(BufferedMessage(name, log_time, log_time, 0, data))
    topics = [SnapshotTopic(t.name, t.type, (contract_qos(t.qos),)) for t in TOPICS]
    last_100ms = buf.window(0.1)
    w = write_snapshot(tmp_path / "snap", last_100ms, topics)
    assert w.message_count == len(last_100ms)
    first = TRAFFIC[-1][1] - 100_000_000
    window = [(n, t, d) for n, t, d, _ in TRAFFIC if t >= first]
    older_latched = [(n, t, d) for n, t, d, _ in TRAFFIC if t < first and n == STATIC_READINGS.name][-1:]
    with open_bag(tmp_path / "snap") as b:
        assert [(m.topic, m.log_time, m.data) for m in b.messages()] == older_latched + window
        assert set(b.topics) == {t.name for t in TOPICS}
