"""A split bag missing one of its files: every command names each missing file, and nothing is called "nothing lost".

``bag recover`` of such a bag had printed ``complete (it had its footer: nothing was lost)`` for
the files it found and exited 0.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from bike_rig.bag.errors import BagReadError
from bike_rig.bag.reader import MCAP_MAGIC, open_bag
from bike_rig.bag.recover import recover_bag, scan_mcap
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config.topics import TOPICS
from bike_rig.offline.info import summarize
from test.support.cli import run_cli
from test.support.samples import sample_traffic

COUNTS = {t.name: n for t, n in zip(TOPICS, (100, 12, 6, 1, 2, 3, 1, 3), strict=True)}
TRAFFIC = sample_traffic(COUNTS)


def split_bag(path: Path, files: int = 4) -> list[Path]:
    """A bag split into ``files`` storage files of about as many messages each."""
    per_file = -(-len(TRAFFIC) // files)
    with BagWriter(path) as w:
        for t in TOPICS:
            w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
        for k, (name, log_time, data, _) in enumerate(TRAFFIC):
            if k and k % per_file == 0:
                w.split()
            w.write(name, log_time, data, sequence=k + 1)
    return [path / name for name in w.files]


def test_a_whole_split_bag_recovers_with_nothing_lost(tmp_path: Path) -> None:
    split_bag(tmp_path / "whole")
    code, out, err = run_cli("bag", "recover", str(tmp_path / "whole"))
    assert (code, err) == (0, "") and out.count("nothing was lost") == 4 and "MISSING" not in out


@pytest.mark.parametrize("gone", [(1,), (3,), (1, 2)], ids=["middle", "last", "two"])
def test_recover_names_every_listed_file_it_cannot_find_and_exits_1(tmp_path: Path, gone: tuple[int, ...]) -> None:
    files = split_bag(tmp_path / "split")
    meta = yaml.safe_load((tmp_path / "split" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    counts = [e["message_count"] for e in meta["files"]]
    for k in gone:
        files[k].unlink()
    recovery = recover_bag(tmp_path / "split", tmp_path / "out")
    assert [m.name for m in recovery.missing] == [files[k].name for k in gone]
    assert all(m.why == "metadata.yaml lists it" for m in recovery.missing)
    assert not recovery.was_complete and not recovery.nothing_lost
    assert recovery.message_count == sum(n for k, n in enumerate(counts) if k not in gone)
    code, out, err = run_cli("bag", "recover", str(tmp_path / "split"), "-o", str(tmp_path / "again"))
    assert code == 1 and err == ""
    assert "nothing was lost" not in out
    for k in gone:
        assert f"  {files[k].name}: MISSING (metadata.yaml lists it): its messages are not recovered" in out
    lines = [line.split(":")[0].strip() for line in out.splitlines() if line.startswith("  split_")]
    assert lines == [f.name for f in files]  # in the recording's order, the missing ones in their place
    assert f"NOT recovered: {len(gone)} storage file(s) missing" in out
    code, out, _ = run_cli("bag", "recover", str(tmp_path / "split"), "-o", str(tmp_path / "json"), "--json")
    report = json.loads(out)
    assert code == 1 and not report["was_complete"] and not report["nothing_lost"]
    assert [m["file"] for m in report["missing"]] == [files[k].name for k in gone]


def test_without_metadata_a_gap_in_the_numbering_is_named(tmp_path: Path) -> None:
    files = split_bag(tmp_path / "crashed")
    (tmp_path / "crashed" / "metadata.yaml").unlink()
    files[1].unlink()
    recovery = recover_bag(tmp_path / "crashed", tmp_path / "out")
    assert [(m.name, m.why) for m in recovery.missing] == [(files[1].name, "the files numbered after it are here")]
    code, out, _ = run_cli("bag", "recover", str(tmp_path / "crashed"), "-o", str(tmp_path / "again"))
    assert code == 1 and f"{files[1].name}: MISSING (the files numbered after it are here)" in out


def test_info_and_replay_name_every_missing_file_in_one_line(tmp_path: Path) -> None:
    files = split_bag(tmp_path / "split")
    files[1].unlink()
    files[3].unlink()
    with pytest.raises(BagReadError, match=r"metadata.yaml lists split_1.mcap and split_3.mcap, which are missing"):
        open_bag(tmp_path / "split")
    with pytest.raises(BagReadError, match="which are missing"):
        summarize(tmp_path / "split")
    for command in (("bag", "info"), ("replay",)):
        code, out, err = run_cli(*command, str(tmp_path / "split"))
        assert code == 2 and out == "" and err.count("\n") == 1
        assert "split_1.mcap and split_3.mcap, which are missing" in err and "bike-rig bag recover" in err


def test_a_storage_file_metadata_does_not_list_is_named(tmp_path: Path) -> None:
    files = split_bag(tmp_path / "split", files=2)
    (tmp_path / "other").mkdir()
    split_bag(tmp_path / "other" / "split", files=3)
    extra = tmp_path / "split" / "split_2.mcap"
    extra.write_bytes((tmp_path / "other" / "split" / "split_2.mcap").read_bytes())
    assert len(files) == 2
    with pytest.raises(BagReadError, match="holds split_2.mcap, which metadata.yaml does not list"):
        open_bag(tmp_path / "split")


def test_a_bag_whose_every_file_is_missing_is_named(tmp_path: Path) -> None:
    for f in split_bag(tmp_path / "gone", files=2):
        f.unlink()
    reason = r"every storage file metadata.yaml lists is missing \(gone_0.mcap, gone_1.mcap\)"
    with pytest.raises(BagReadError, match=reason):
        recover_bag(tmp_path / "gone")


def test_a_split_file_cut_as_it_was_created_is_recovered_as_empty(tmp_path: Path) -> None:
    """A recorder killed right after a split leaves the next file empty (or a few bytes of the magic)."""
    for size in (0, 3):
        cut = tmp_path / f"cut_{size}.mcap"
        cut.write_bytes(MCAP_MAGIC[:size])
        scan = scan_mcap(cut)
        assert not scan.complete and scan.messages == [] and "cut before its first record" in scan.stop_reason
