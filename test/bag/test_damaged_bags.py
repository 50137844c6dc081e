"""Damaged bags end in one BagReadError naming the file, the place and the reason (issue 12).

Each case was a traceback before: metadata.yaml nested thousands of levels deep
(RecursionError), infinite counts or lists where scalars belong (OverflowError, TypeError), a
corrupt zstd chunk (ZstdError), impossible MCAP record lengths (MemoryError, OverflowError).
"""

from __future__ import annotations

import shutil
import struct
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.records import ChunkIndex

from bike_rig.bag.check import MAX_CHUNK_BYTES
from bike_rig.bag.errors import BagReadError
from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.config.paths import config_file
from bike_rig.core.sim import load_rig, load_true_parameters, simulate_session
from bike_rig.offline.info import summarize
from bike_rig.offline.session import read_session
from test.support.small_sessions import small_rig


def small_bag(directory: Path) -> Path:
    """A bag of a short simulated Browser session (1 s trials), zstd chunks; about 50 kB."""
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    session = simulate_session(truth, load_rig(small_rig(directory, duration_s=1.0)), 3, name)
    return write_simulated_bag(directory / "bag", session)


@pytest.fixture(scope="module")
def pristine(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return small_bag(tmp_path_factory.mktemp("damaged"))


@pytest.fixture
def bag(pristine: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(pristine, tmp_path / "bag"))


def _edit_metadata(bag: Path, edit: Callable[[str], str]) -> None:
    meta = bag / "metadata.yaml"
    text = meta.read_text()
    new = edit(text)
    assert new != text
    meta.write_text(new)


def _edit_mcap(bag: Path, edit: Callable[[bytearray], None]) -> None:
    mcap = bag / "bag_0.mcap"
    data = bytearray(mcap.read_bytes())
    edit(data)
    mcap.write_bytes(bytes(data))


def _refused(bag: Path, *parts: str) -> str:
    with pytest.raises(BagReadError) as info:
        read_session(bag)
    text = str(info.value)
    assert "\n" not in text and text.startswith(str(bag)), text
    for part in parts:
        assert part in text, text
    return text


def test_the_small_bag_reads(pristine: Path) -> None:
    session = read_session(pristine)
    assert session.message_count > 100 and session.trials
    assert summarize(pristine).message_count == session.message_count == 287


@pytest.mark.parametrize("where", ["document", "custom_data"])
def test_deeply_nested_metadata_is_refused(bag: Path, where: str) -> None:
    deep = "[" * 5000 + "]" * 5000
    if where == "document":
        _edit_metadata(bag, lambda _: deep)
    else:
        _edit_metadata(bag, lambda t: t.replace("custom_data: null", f"custom_data: {deep}"))
    _refused(bag, "metadata.yaml line", "nested deeper than 64 levels")


@pytest.mark.parametrize(
    ("old", "new", "place", "reason"),
    [
        ("message_count: 287", "message_count: .inf", "rosbag2_bagfile_information.message_count", "not a finite"),
        ("message_count: 287", "message_count: [1, 2]", "rosbag2_bagfile_information.message_count", "not an integer"),
        ("message_count: 287", "message_count: -3", "rosbag2_bagfile_information.message_count", "negative count"),
        ("message_count: 260", "message_count: .nan", "topics_with_message_count[0].message_count", "not a finite"),
        ("name: /bike_rig/gyro", "name: [a]", "topics_with_message_count[0].topic_metadata.name", "not a string"),
        (
            "nanoseconds: 143000001000",
            "nanoseconds: {a: 1}",
            "rosbag2_bagfile_information.duration.nanoseconds",
            "not an integer",
        ),
        ("version: 9", "version: [9]", "rosbag2_bagfile_information.version", "not an integer"),
        ("- bag_0.mcap", "- [bag_0.mcap]", "relative_file_paths[0]", "not a string"),
        ("depth: 50000", "depth: [1]", "offered_qos_profiles[0].depth", "not a QoS policy"),
    ],
)
def test_metadata_values_of_the_wrong_type_are_refused(bag: Path, old: str, new: str, place: str, reason: str) -> None:
    _edit_metadata(bag, lambda t: t.replace(old, new, 1))
    _refused(bag, "metadata.yaml: rosbag2_bagfile_information.", f"{place}: ", reason)


def test_metadata_alias_bomb_is_refused_quickly(bag: Path) -> None:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [*a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}]" for i in range(1, 12)]
    _edit_metadata(bag, lambda t: "\n".join(lines) + "\n" + t)
    _refused(bag, "metadata.yaml", "values")


def _chunks(path: Path) -> list[ChunkIndex]:
    """The chunk indexes of an MCAP file, in file order (read with the mcap library)."""
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)


def _chunk_offset(bag: Path) -> int:
    return int(_chunks(bag / "bag_0.mcap")[0].chunk_start_offset)


def test_a_corrupt_zstd_chunk_is_named_by_its_offset(bag: Path) -> None:
    offset = _chunk_offset(bag)

    def corrupt(data: bytearray) -> None:
        at = offset + 9 + 8 + 8 + 8 + 4  # opcode, length, start, end, uncompressed size, crc
        at += 4 + struct.unpack_from("<I", data, at)[0] + 8  # compression name, compressed size
        for i in range(at + 20, at + 60):
            data[i] ^= 0x55

    _edit_mcap(bag, corrupt)
    _refused(bag, f"bag_0.mcap: chunk at byte {offset} is corrupt", "decompress")


def _summary_start(data: bytearray) -> int:
    return int(struct.unpack_from("<Q", data, len(data) - 37 + 9)[0])


def test_of_several_corrupt_chunks_the_first_is_named(tmp_path: Path) -> None:
    """Chunks unpack on every core; the error still names the first corrupt one in the file."""
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    session = simulate_session(truth, load_rig(small_rig(tmp_path, duration_s=1.0)), 3, name)
    bag = write_simulated_bag(tmp_path / "bag", session, chunk_size=4096)
    assert read_session(bag).trials  # (it reads, undamaged)
    chunks = _chunks(bag / "bag_0.mcap")
    assert len(chunks) >= 6

    def corrupt(data: bytearray) -> None:
        for chunk in (chunks[2], chunks[5]):
            at = chunk.chunk_start_offset + 9 + 8 + 8 + 8 + 4  # opcode, length, start, end, uncompressed size, crc
            at += 4 + struct.unpack_from("<I", data, at)[0] + 8  # compression name, compressed size
            for i in range(at + 20, at + 60):
                data[i] ^= 0x55

    _edit_mcap(bag, corrupt)
    _refused(bag, f"bag_0.mcap: chunk at byte {chunks[2].chunk_start_offset} is corrupt", "decompress")


@pytest.mark.parametrize("length", [2**63, 2**64 - 1, 10**10])
def test_an_impossible_summary_record_length_is_refused(bag: Path, length: int) -> None:
    def lengthen(data: bytearray) -> None:
        start = _summary_start(data)
        data[start + 1 : start + 9] = struct.pack("<Q", length)

    _edit_mcap(bag, lengthen)
    _refused(bag, "bag_0.mcap: record at byte", f"a length of {length} bytes beyond", "(corrupt)")


def test_an_impossible_header_length_is_refused(bag: Path) -> None:
    _edit_mcap(bag, lambda data: data.__setitem__(slice(9, 17), struct.pack("<Q", 2**62)))
    _refused(bag, "bag_0.mcap: header record at byte 8", str(2**62))


def test_a_chunk_index_pointing_elsewhere_is_refused(bag: Path) -> None:
    offset = _chunk_offset(bag)
    _edit_mcap(bag, lambda data: data.__setitem__(slice(offset + 1, offset + 9), struct.pack("<Q", 2**62)))
    _refused(bag, f"chunk at byte {offset}: not the chunk record")


def test_a_huge_uncompressed_size_in_a_chunk_index_is_refused(bag: Path) -> None:
    chunk = _chunks(bag / "bag_0.mcap")[0]

    def enlarge(data: bytearray) -> None:
        start = _summary_start(data)
        body = bytes(data[start:])
        old = struct.pack("<QQ", chunk.compressed_size, chunk.uncompressed_size)
        at = start + body.index(old) + 8
        data[at : at + 8] = struct.pack("<Q", MAX_CHUNK_BYTES + 1)

    _edit_mcap(bag, enlarge)
    _refused(bag, f"chunk at byte {chunk.chunk_start_offset}", "bytes uncompressed")


def test_a_duplicate_metadata_key_is_one_line(bag: Path) -> None:
    """The YAML parser of rosbags refuses it in a message of several lines: it is said in one."""
    _edit_metadata(bag, lambda t: t.replace("depth: 50000", "depth: 50000\n        depth: 1", 1))
    _refused(bag, "unreadable bag", "duplicate key")


def test_a_count_that_is_a_word_is_refused(bag: Path) -> None:
    _edit_metadata(bag, lambda t: t.replace("message_count: 260", "message_count: inf", 1))
    _refused(bag, "topic '/bike_rig/gyro': message count 'inf' is not an integer")


REPO = Path(__file__).resolve().parents[2]


def _deep(bag: Path) -> None:
    _edit_metadata(bag, lambda _: "[" * 5000 + "]" * 5000)


def _corrupt_first_chunk(bag: Path) -> None:
    offset = _chunk_offset(bag)

    def corrupt(data: bytearray) -> None:
        at = offset + 9 + 8 + 8 + 8 + 4
        at += 4 + struct.unpack_from("<I", data, at)[0] + 8
        for i in range(at + 20, at + 60):
            data[i] ^= 0x55

    _edit_mcap(bag, corrupt)


def _header_length(bag: Path) -> None:
    _edit_mcap(bag, lambda data: data.__setitem__(slice(9, 17), struct.pack("<Q", 2**62)))


CLI_CASES = [
    (["bag", "info"], _deep, "bike-rig bag: error: ", "nested deeper than 64 levels"),
    (["replay"], _deep, "bike-rig replay: error: ", "nested deeper than 64 levels"),
    (["bag", "info"], _corrupt_first_chunk, "bike-rig bag: error: ", "is corrupt"),
    (["replay"], _corrupt_first_chunk, "bike-rig replay: error: ", "is corrupt"),
    (["bag", "info"], _header_length, "bike-rig bag: error: ", "header record at byte 8"),
    (["replay"], _header_length, "bike-rig replay: error: ", "header record at byte 8"),
    (["bag", "recover"], _header_length, "bike-rig bag: error: ", "implausible record length"),
]


@pytest.mark.parametrize(
    ("command", "damage", "prefix", "reason"),
    CLI_CASES,
    ids=[f"{' '.join(c)}-{d.__name__.strip('_')}" for c, d, _, _ in CLI_CASES],
)
def test_the_cli_says_it_in_one_line_with_exit_2(
    bag: Path, command: list[str], damage: Callable[[Path], None], prefix: str, reason: str
) -> None:
    damage(bag)
    done = subprocess.run(
        [sys.executable, "-m", "bike_rig.cli.main", *command, str(bag)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    lines = done.stderr.splitlines()
    assert done.returncode == 2, done.stderr
    assert len(lines) == 1 and lines[0].startswith(prefix), done.stderr
    assert reason in lines[0]


def test_metadata_with_an_unreadable_scalar_is_refused(bag: Path) -> None:
    _edit_metadata(bag, lambda t: t.replace("custom_data: null", "custom_data:\n    when: 2001-13-45", 1))
    _refused(bag, "metadata.yaml: a value cannot be read")


def test_metadata_with_aliases_is_read_by_the_bounded_loader(bag: Path) -> None:
    _edit_metadata(bag, lambda t: t.replace("custom_data: null", "custom_data:\n    a: &x seen\n    b: *x", 1))
    assert read_session(bag).message_count == 287


def test_a_bag_message_count_that_is_text_is_refused(bag: Path) -> None:
    """YAML 1.2 (rosbags) reads ``=287`` as text: found by the fuzzer (seed 20261126, bag-metadata#8995)."""
    _edit_metadata(bag, lambda t: t.replace("message_count: 287", "message_count: =287", 1))
    _refused(bag, "metadata.yaml: the message count, start or duration is not an integer")


def test_a_files_entry_without_a_path_is_skipped(bag: Path) -> None:
    """Found by the fuzzer (seed 20261126, bag-metadata#7666): a KeyError before."""
    _edit_metadata(bag, lambda t: t.replace("  - path: bag_0.mcap", "  - pat: bag_0.mcap", 1))
    assert read_session(bag).message_count == 287


def _deep_qos_bag(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A small bag whose channels' offered-QoS text nests 200,000 lists deep."""
    monkeypatch.setattr("bike_rig.bag.writer._qos_yaml", lambda _profiles: "[" * 200_000 + "]" * 200_000)
    return small_bag(tmp_path)


def _bag_command(command: str, bag: Path) -> subprocess.CompletedProcess[str]:
    """``bike-rig bag COMMAND BAG`` in a process of its own (a crash must not take the test down)."""
    return subprocess.run(
        [sys.executable, "-m", "bike_rig.cli.main", "bag", command, str(bag)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_channel_qos_text_nested_200000_deep_is_refused_without_a_crash(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The composer of libyaml recursed on it until the process died (SIGSEGV): it is refused in one line."""
    done = _bag_command("info", _deep_qos_bag(tmp_path, monkeypatch))
    lines = done.stderr.splitlines()
    assert done.returncode == 2, done.stderr[-500:]
    assert len(lines) == 1 and "offered QoS profiles: nested deeper than 64 levels" in lines[0], done.stderr


def test_bag_recover_drops_a_channel_qos_text_nested_200000_deep(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The recovered bag keeps every message; the QoS text no parser may load is left out."""
    done = _bag_command("recover", _deep_qos_bag(tmp_path, monkeypatch))
    assert done.returncode == 0, done.stderr[-500:]
    assert "recovered 287 messages" in done.stdout
    assert read_session(tmp_path / "bag_recovered").message_count == 287


def test_a_bad_explicit_tag_in_metadata_is_refused(bag: Path) -> None:
    """Found by the fuzzer (seed 20261126, bag-metadata#8553): PyYAML's AttributeError before."""
    tagged = "!!timestamp durability: transient_local"
    _edit_metadata(bag, lambda t: t.replace("durability: transient_local", tagged, 1))
    _refused(bag, "metadata.yaml: a value cannot be read")
