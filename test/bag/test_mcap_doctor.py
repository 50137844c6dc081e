"""Every storage file the writer makes passes the MCAP format's own checks.

As the official ``mcap doctor`` makes them: every schema and channel of the summary section is
in the data section too (its error "Schema/Channel with id N in summary section does not exist
in data section"), and the file reads strictly (checksums validated) with the mcap library.
"""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader
from mcap.records import Channel, DataEnd, Schema
from mcap.stream_reader import StreamReader

from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config.topics import GYRO, PERIODS, READINGS, TOPICS, TRIAL_EVENTS
from test.support.samples import sample_traffic


def data_and_summary(path: Path) -> tuple[set[tuple[str, int]], set[tuple[str, int]], int]:
    """The (kind, id) of the schemas and channels in the data section, in the summary, and the messages read."""
    in_data: set[tuple[str, int]] = set()
    with path.open("rb") as f:
        for record in StreamReader(f, validate_crcs=True).records:  # chunks unpacked, CRCs checked
            if isinstance(record, DataEnd):
                break
            if isinstance(record, Schema | Channel):
                in_data.add((type(record).__name__, record.id))
    with path.open("rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None
        in_summary = {("Schema", i) for i in summary.schemas} | {("Channel", i) for i in summary.channels}
        messages = sum(1 for _ in reader.iter_messages())
    return in_data, in_summary, messages


def test_topics_without_messages_leave_no_channel_in_the_summary(tmp_path: Path) -> None:
    counts = {GYRO.name: 40, TRIAL_EVENTS.name: 4, PERIODS.name: 2}
    traffic = sample_traffic({t.name: counts.get(t.name, 0) for t in TOPICS})
    with BagWriter(tmp_path / "bag", chunk_size=3000) as w:
        for t in TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for k, (name, log_time, data, _) in enumerate(traffic):
            if k == len(traffic) // 2:
                w.split()
            w.write(name, log_time, data)
    files = sorted((tmp_path / "bag").glob("*.mcap"))
    assert len(files) >= 2  # (split: each file registers what it holds)
    seen_topics: set[str] = set()
    for path in files:
        in_data, in_summary, messages = data_and_summary(path)
        assert in_summary <= in_data, f"{path.name}: in the summary, not in the data section: {in_summary - in_data}"
        assert messages > 0
        with path.open("rb") as f:
            summary = make_reader(f).get_summary()
        assert summary is not None
        seen_topics |= {c.topic for c in summary.channels.values()}
    assert seen_topics == set(counts)
    assert READINGS.name not in seen_topics  # added, never written: listed in metadata.yaml only
    assert READINGS.name in (tmp_path / "bag" / "metadata.yaml").read_text()


def test_an_empty_bag_has_no_channels(tmp_path: Path) -> None:
    with BagWriter(tmp_path / "empty") as w:
        for t in TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
    (path,) = sorted((tmp_path / "empty").glob("*.mcap"))
    in_data, in_summary, messages = data_and_summary(path)
    assert in_summary <= in_data and messages == 0


def test_schemas_keep_each_msg_file_verbatim(tmp_path: Path) -> None:
    """As rosbag2 stores them: the .msg text with its comments and units, then each dependency's."""
    from bike_rig.bag.typestore import find_msg_dir

    traffic = sample_traffic({t.name: 1 for t in TOPICS})
    with BagWriter(tmp_path / "bag") as w:
        for t in TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for name, log_time, data, _ in traffic:
            w.write(name, log_time, data)
    (path,) = sorted((tmp_path / "bag").glob("*.mcap"))
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    schemas = {s.name: s.data.decode() for s in summary.schemas.values()}
    gyro = (find_msg_dir() / "GyroBatch.msg").read_text(encoding="utf-8")
    assert "#" in gyro  # (the file has comments to keep)
    assert schemas[GYRO.type].startswith(gyro.rstrip("\n") + "\n")
    assert "\nMSG: std_msgs/Header\n" in schemas[GYRO.type]
