"""Another tool's MCAP file: one line naming the file and why, a non-zero status, never a traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from mcap.writer import Writer

from bike_rig.bag.errors import NotABagError
from bike_rig.bag.reader import open_bag
from bike_rig.bag.recover import recover_bag
from bike_rig.bag.typestore import message_definition
from bike_rig.config.topics import GYRO, STATIC_READINGS
from test.support.cli import run_cli
from test.support.samples import make_message, serialize

REPO = Path(__file__).resolve().parents[2]
CDR_ZERO = b"\x00\x01\x00\x00" + bytes(8)


def write_mcap(path: Path, profile: str, channels: list[tuple[str, tuple[str, str, bytes] | None, str, bytes]]) -> Path:
    """An MCAP file written by the mcap library: per channel (topic, schema (name, encoding, data), encoding, data)."""
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile=profile, library="another tool")
        for topic, schema, encoding, data in channels:
            sid = w.register_schema(*schema) if schema is not None else 0
            cid = w.register_channel(topic, encoding, sid)
            for k in range(3):
                w.add_message(cid, log_time=1000 + k, data=data, publish_time=1000 + k, sequence=k + 1)
        w.finish()
    return path


JSON = ("Foo", "jsonschema", b'{"type": "object"}')
#: (file, profile, channels, reason)
SHAPES = [
    ("json", "", [("/x", JSON, "json", b'{"a": 1}')], "channel /x has message encoding 'json'"),
    ("json_ros2", "ros2", [(GYRO.name, JSON, "json", b'{"a": 1}')], f"channel {GYRO.name} has message encoding 'json'"),
    (
        "protobuf",
        "",
        [("/x", ("pkg.Foo", "protobuf", b"\x0a\x00"), "protobuf", b"\x08\x01")],
        "channel /x has message encoding 'protobuf'",
    ),
    ("no_schema", "ros2", [(GYRO.name, None, "cdr", CDR_ZERO)], f"channel {GYRO.name} has no schema"),
    ("empty", "", [], "MCAP profile '' is not 'ros2'"),
    (
        "jsonschema_cdr",
        "ros2",
        [(GYRO.name, JSON, "cdr", CDR_ZERO)],
        f"channel {GYRO.name}: its schema Foo has encoding 'jsonschema'",
    ),
    (
        "idl",
        "ros2",
        [
            (
                GYRO.name,
                (GYRO.type, "ros2idl", b"module bike_rig_msgs { module msg { struct GyroBatch { double x; }; }; };"),
                "cdr",
                CDR_ZERO,
            )
        ],
        "",
    ),
]


@pytest.mark.parametrize(("name", "profile", "channels", "reason"), SHAPES, ids=[s[0] for s in SHAPES])
def test_no_command_tracebacks_on_a_foreign_mcap(
    tmp_path: Path,
    name: str,
    profile: str,
    channels: list[tuple[str, tuple[str, str, bytes] | None, str, bytes]],
    reason: str,
) -> None:
    path = write_mcap(tmp_path / f"{name}.mcap", profile, channels)
    for command in (("bag", "info"), ("bag", "recover"), ("replay",)):
        extra = ("-o", str(tmp_path / "out")) if command[-1] == "recover" else ()
        code, out, err = run_cli(*command, str(path), *extra)
        assert code != 0 and out == "", (command, out)
        assert err.count("\n") == 1 and err.startswith(f"bike-rig {command[0]}: error: {path}: "), (command, err)
        if reason and (command[-1] != "recover" or name != "empty"):
            assert f"not a ROS 2 CDR bag: {reason}" in err, (command, err)
    if name == "idl":  # a ROS 2 schema, but not a GyroBatch bike_rig can read
        _, _, err = run_cli("replay", str(path))
        assert "GyroBatch has no field header" in err and err.count("RIHS01_") == 2


def test_the_json_mcap_in_a_process_of_its_own(tmp_path: Path) -> None:
    path = write_mcap(tmp_path / "foxglove.mcap", "", [("/x", JSON, "json", b'{"a": 1}')])
    for command in (["bag", "recover"], ["bag", "info"], ["replay"]):
        done = subprocess.run(
            [sys.executable, "-m", "bike_rig.cli.main", *command, str(path)],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
        assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
        assert done.stderr == (
            f"bike-rig {command[0]}: error: {path}: not a ROS 2 CDR bag: channel /x has message encoding 'json'\n"
        )


def test_a_foreign_file_in_a_bag_directory_is_named(tmp_path: Path) -> None:
    bag = tmp_path / "bag"
    bag.mkdir()
    write_mcap(bag / "bag_0.mcap", "", [("/x", JSON, "json", b"{}")])
    with pytest.raises(NotABagError, match=r"bag_0.mcap: not a ROS 2 CDR bag: channel /x has message encoding 'json'"):
        recover_bag(bag, tmp_path / "out")


def test_recover_copies_the_ros2_channels_and_names_the_others(tmp_path: Path) -> None:
    readings = make_message(STATIC_READINGS.type, 1)
    schema = (STATIC_READINGS.type, "ros2msg", message_definition(STATIC_READINGS.type).encode())
    path = write_mcap(
        tmp_path / "mixed.mcap",
        "ros2",
        [
            (STATIC_READINGS.name, schema, "cdr", serialize(readings)),
            ("/foxglove/markers", JSON, "json", b"{}"),
        ],
    )
    with pytest.raises(NotABagError, match="channel /foxglove/markers has message encoding 'json'"):
        open_bag(path)
    recovery = recover_bag(path, tmp_path / "out")
    assert recovery.message_count == 3 and not recovery.nothing_lost
    (skipped,) = recovery.skipped
    assert skipped == "mixed.mcap: channel /foxglove/markers has message encoding 'json' (3 messages not copied)"
    with open_bag(recovery.output) as b:
        assert list(b.topics) == [STATIC_READINGS.name]
    code, out, err = run_cli("bag", "recover", str(path), "-o", str(tmp_path / "again"))
    assert code == 1 and err == ""
    assert "skipped mixed.mcap: channel /foxglove/markers" in out and "nothing was lost" not in out
