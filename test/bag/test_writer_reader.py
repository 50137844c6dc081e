"""Bags written from raw CDR read back with rosbags (typestore) and with mcap's own reader."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader

from bike_rig.bag import typestore as typestore_mod
from bike_rig.bag.errors import BagError, BagExistsError, IncompleteBagError, NotABagError
from bike_rig.bag.reader import open_bag
from bike_rig.bag.recover import scan_mcap
from bike_rig.bag.typestore import find_msg_dir, rig_typestore, standard_typestore, type_hash
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config.topics import GYRO, TOPICS
from test.support.samples import as_plain, sample_traffic

COUNTS = {t.name: n for t, n in zip(TOPICS, (40, 7, 5, 1, 2, 3, 1, 3))}


def write_bag(path: Path, compression: str = "zstd") -> list[tuple[str, int, bytes, object]]:
    traffic = sample_traffic(COUNTS)
    with BagWriter(path, compression=compression) as w:
        for t in TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for k, (name, log_time, data, _) in enumerate(traffic):
            w.write(name, log_time, data, publish_time=log_time - 1000, sequence=k + 1)
    return traffic


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_rosbags_reads_back_every_message(tmp_path: Path, compression: str) -> None:
    bag = tmp_path / "bag"
    traffic = write_bag(bag, compression)
    store = rig_typestore()
    with Reader(bag) as reader:
        assert {c.topic: c.msgcount for c in reader.connections} == COUNTS
        got = [(c.topic, t, bytes(d)) for c, t, d in reader.messages()]
        decoded = [as_plain(store.deserialize_cdr(d, c.msgtype)) for c, _, d in reader.messages()]
    assert got == [(name, t, data) for name, t, data, _ in traffic]
    assert decoded == [as_plain(m) for *_, m in traffic]


def test_mcap_reader_sees_ros2_profile_schemas_channels_and_counts(tmp_path: Path) -> None:
    bag = tmp_path / "session"
    traffic = write_bag(bag)
    with (bag / "session_0.mcap").open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        channels = {c.topic: c for c in summary.channels.values()}
        assert set(channels) == {t.name for t in TOPICS}
        for t in TOPICS:
            ch = channels[t.name]
            schema = summary.schemas[ch.schema_id]
            assert (ch.message_encoding, schema.encoding, schema.name) == ("cdr", "ros2msg", t.type)
            assert ch.metadata["topic_type_hash"] == type_hash(t.type)
            assert "reliability: reliable" in ch.metadata["offered_qos_profiles"]
        counts = {summary.channels[cid].topic: n for cid, n in summary.statistics.channel_message_counts.items()}
        assert counts == COUNTS
        decoded = [
            (ch.topic, msg.log_time, msg.publish_time, dec) for _, ch, msg, dec in reader.iter_decoded_messages()
        ]
    assert [(n, t) for n, t, *_ in decoded] == [(n, t) for n, t, *_ in traffic]
    assert all(pub == log - 1000 for _, log, pub, _ in decoded)
    # mcap_ros2 decodes from the embedded schema alone: spot-check the content
    first_gyro = next(d for n, _, _, d in decoded if n == GYRO.name)
    expected = next(m for n, _, _, m in traffic if n == GYRO.name)
    assert list(first_gyro.rates) == list(expected.rates)  # type: ignore[attr-defined]
    assert first_gyro.trial_id == expected.trial_id  # type: ignore[attr-defined]


def test_metadata_yaml_is_rosbag2_version_9(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    traffic = write_bag(bag)
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9
    assert info["storage_identifier"] == "mcap"
    assert info["relative_file_paths"] == ["bag_0.mcap"]
    assert info["message_count"] == len(traffic) == info["files"][0]["message_count"]
    assert info["starting_time"]["nanoseconds_since_epoch"] == traffic[0][1]
    assert info["duration"]["nanoseconds"] == traffic[-1][1] - traffic[0][1]
    assert info["ros_distro"] == "kilted"
    share = Path(sys.prefix) / "share" / "bike_rig_msgs" / "msg"
    by_name = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    for t in TOPICS:
        meta = by_name[t.name]["topic_metadata"]
        assert by_name[t.name]["message_count"] == COUNTS[t.name]
        assert meta["type"] == t.type and meta["serialization_format"] == "cdr"
        rosidl = json.loads((share / f"{t.type.rsplit('/', 1)[1]}.json").read_text())
        assert meta["type_description_hash"] == rosidl["type_hashes"][0]["hash_string"]
        (qos,) = meta["offered_qos_profiles"]  # v9: a list of mappings
        assert qos["depth"] == t.qos.depth
        assert qos["durability"] == ("transient_local" if t.qos.transient_local else "volatile")


def test_typestore_uses_the_installed_definitions() -> None:
    assert find_msg_dir() == Path(sys.prefix) / "share" / "bike_rig_msgs" / "msg"


def test_the_rig_store_takes_standard_types_from_their_installed_msg_files() -> None:
    """The rig's store parses Header/Time from the prefix, and every hash equals Kilted's."""
    rig, full = rig_typestore(), standard_typestore()
    assert "std_msgs/msg/Header" in rig.fielddefs and "builtin_interfaces/msg/Time" in rig.fielddefs
    assert "std_msgs/msg/String" not in rig.fielddefs and "std_msgs/msg/String" in full.fielddefs
    for t in TOPICS:
        assert rig.hash_rihs01(t.type) == full.hash_rihs01(t.type)
    assert type_hash("std_msgs/msg/String") == full.hash_rihs01("std_msgs/msg/String")


def test_without_installed_standard_msg_files_the_rig_store_is_kilted_s(monkeypatch: pytest.MonkeyPatch) -> None:
    expected = {t.type: type_hash(t.type) for t in TOPICS}
    monkeypatch.setattr(typestore_mod, "_installed_msg", lambda *_: None)
    typestore_mod.rig_typestore.cache_clear()
    try:
        store = typestore_mod.rig_typestore()
        assert "std_msgs/msg/String" in store.fielddefs  # the whole distribution
        assert {t.type: store.hash_rihs01(t.type) for t in TOPICS} == expected
    finally:
        typestore_mod.rig_typestore.cache_clear()


def test_bag_reader_reports_topics_times_and_decodes(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    traffic = write_bag(bag)
    with open_bag(bag) as b:
        assert {n: t.count for n, t in b.topics.items()} == COUNTS
        assert b.start_time == traffic[0][1] and b.end_time == traffic[-1][1]
        assert b.message_count == len(traffic)
        got = [(n, as_plain(m)) for n, _, m in b.decoded([GYRO.name])]
    assert got == [(n, as_plain(m)) for n, _, _, m in traffic if n == GYRO.name]


def test_a_bag_is_never_overwritten(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    write_bag(bag)
    with pytest.raises(BagExistsError, match="exists already"):
        BagWriter(bag).open()


def test_flushed_chunks_are_on_disk_before_close(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    w = BagWriter(bag, flush_period_s=0.5)
    w.open()
    w.add_topic(GYRO.name, GYRO.type)
    for name, t, data, _ in sample_traffic({GYRO.name: 30}):
        w.write(name, t, data)
    assert scan_mcap(w.data_path).messages == []  # still in the chunk in progress
    assert w.flush_if_due(now=1e12)
    scan = scan_mcap(w.data_path)
    assert len(scan.messages) == 30 and not scan.complete
    w.abort()
    with pytest.raises(IncompleteBagError, match="bag recover"):
        open_bag(bag)


def test_bad_input_gives_one_line_errors(tmp_path: Path) -> None:
    (tmp_path / "empty_dir").mkdir()
    (tmp_path / "notes.txt").write_text("hello\n")
    (tmp_path / "fake.mcap").write_bytes(b"not mcap at all")
    cases = {
        tmp_path / "missing": (BagError, "no such file"),
        tmp_path / "empty_dir": (NotABagError, "not a rosbag2 bag"),
        tmp_path / "notes.txt": (NotABagError, "not a bag"),
        tmp_path / "fake.mcap": (NotABagError, "not an MCAP file"),
    }
    for path, (kind, reason) in cases.items():
        with pytest.raises(kind) as err:
            open_bag(path)
        text = str(err.value)
        assert text.startswith(str(path)) and reason in text and "\n" not in text
