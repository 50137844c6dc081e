"""bag recover: a bag cut anywhere gives back exactly the messages of its complete chunks."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from bike_rig.bag.errors import BagExistsError, BagReadError, NotABagError
from bike_rig.bag.reader import open_bag
from bike_rig.bag.recover import recover_bag, scan_mcap
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config.topics import GYRO, STATIC_READINGS, TRIAL_EVENTS
from test.support.samples import sample_traffic

TOPICS = (STATIC_READINGS, TRIAL_EVENTS, GYRO)


def write_flushed(bag: Path, flush_every: int = 10) -> tuple[list[tuple[str, int, bytes]], list[tuple[int, int]]]:
    """A bag left as a crash leaves it (no close).

    Returns the traffic and, after each flush, (file size, messages flushed).
    """
    traffic = [
        (n, t, d) for n, t, d, _ in sample_traffic({STATIC_READINGS.name: 1, TRIAL_EVENTS.name: 6, GYRO.name: 60})
    ]
    boundaries = []
    w = BagWriter(bag, flush_period_s=1e9)
    w.open()
    for t in TOPICS:
        w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
    for k, (name, log_time, data) in enumerate(traffic, start=1):
        w.write(name, log_time, data, sequence=k)
        if k % flush_every == 0:
            w.flush()
            boundaries.append((w.data_path.stat().st_size, k))
    w.abort()
    return traffic, boundaries


def cut_copy(bag: Path, dest: Path, size: int) -> Path:
    dest.mkdir()
    data = (bag / f"{bag.name}_0.mcap").read_bytes()[:size]
    (dest / f"{dest.name}_0.mcap").write_bytes(data)
    return dest


def test_any_cut_recovers_exactly_the_complete_chunks(tmp_path: Path) -> None:
    bag = tmp_path / "crashed"
    traffic, boundaries = write_flushed(bag)
    size = (bag / "crashed_0.mcap").stat().st_size
    chunk_ends = scan_mcap(bag / "crashed_0.mcap").chunk_ends
    assert [n for _, n in chunk_ends] == [n for _, n in boundaries]
    cuts = sorted({*range(200, size, 233), *(e + d for e, _ in chunk_ends for d in (-1, 0, 1)), size})
    for i, cut in enumerate(cuts):
        src = cut_copy(bag, tmp_path / f"cut{i}", cut)
        flushed = max((n for end, n in chunk_ends if end <= cut), default=0)
        if flushed == 0:
            with pytest.raises(BagReadError, match="nothing to recover"):
                recover_bag(src)
            continue
        recovery = recover_bag(src, tmp_path / f"out{i}")
        assert recovery.message_count == flushed, cut
        with open_bag(recovery.output) as b:
            got = [(m.topic, m.log_time, m.data) for m in b.messages()]
        assert got == traffic[:flushed]
        assert (recovery.output / "metadata.yaml").is_file()


def test_recovery_keeps_qos_hash_schema_and_reports_per_topic(tmp_path: Path) -> None:
    bag = tmp_path / "crashed"
    traffic, boundaries = write_flushed(bag)
    recovery = recover_bag(bag)
    assert recovery.output == tmp_path / "crashed_recovered"
    n = boundaries[-1][1]
    expected = {t.name: sum(1 for name, *_ in traffic[:n] if name == t.name) for t in TOPICS}
    assert {t.name: t.count for t in recovery.topics} == expected
    assert recovery.lost_bytes == (bag / "crashed_0.mcap").stat().st_size - boundaries[-1][0]
    with open_bag(recovery.output) as b:
        for t in TOPICS:
            info = b.topics[t.name]
            assert info.msgtype == t.type
            assert info.offered_qos == (contract_qos(t.qos),)
            assert info.type_hash.startswith("RIHS01_")
    scan = scan_mcap(recovery.output / "crashed_recovered_0.mcap")
    assert scan.complete and [m.sequence for m in scan.messages] == list(range(1, n + 1))


def test_a_corrupt_chunk_is_skipped_and_the_rest_recovered(tmp_path: Path) -> None:
    bag = tmp_path / "crashed"
    _, boundaries = write_flushed(bag)
    data = bytearray((bag / "crashed_0.mcap").read_bytes())
    start, end = boundaries[1][0], boundaries[2][0]
    middle = (start + end) // 2
    data[middle] ^= 0xFF  # inside the third chunk's compressed data
    damaged = tmp_path / "damaged"
    damaged.mkdir()
    (damaged / "damaged_0.mcap").write_bytes(bytes(data))
    recovery = recover_bag(damaged)
    (scan,) = recovery.files
    assert scan.bad_chunks == 1
    assert recovery.message_count == boundaries[-1][1] - 10


def test_recover_refuses_bad_input_and_existing_output(tmp_path: Path) -> None:
    bag = tmp_path / "crashed"
    write_flushed(bag)
    (tmp_path / "crashed_recovered").mkdir()
    with pytest.raises(BagExistsError, match="exists already"):
        recover_bag(bag)
    (tmp_path / "text").mkdir()
    (tmp_path / "text" / "x.mcap").write_text("hello")
    with pytest.raises(NotABagError, match="not an MCAP file"):
        recover_bag(tmp_path / "text")
    with pytest.raises(NotABagError, match="no .mcap file"):
        recover_bag(tmp_path / "crashed_recovered")
    shutil.rmtree(tmp_path / "crashed_recovered")
    assert recover_bag(bag / "crashed_0.mcap", tmp_path / "from_file").message_count > 0
