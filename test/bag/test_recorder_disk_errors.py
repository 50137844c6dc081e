"""Writing a bag onto a real small filesystem that runs out of space or inodes, or turns read-only.

Each test mounts its own tmpfs (root or CAP_SYS_ADMIN is needed; the test is skipped, saying
so, when mount is refused) and unmounts it afterwards. Whatever write fails (a split's closing
records, the next storage file, metadata.yaml at close), the writer raises ``OSError`` with the
errno, leaves nothing half-written that would spoil recovery, and ``bike-rig bag recover``
gets back every message written before. The recorder node turns that error into its one
"recording stopped" line and exit status 1, with no traceback.
"""

from __future__ import annotations

import errno
import json
import os
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from bike_rig.bag.reader import open_bag
from bike_rig.bag.recover import recover_bag, scan_mcap
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config.topics import GYRO, STATIC_READINGS, TOPICS
from test.support.cli import run_cli
from test.support.nodes import node_environment
from test.support.probe import STEP_TIMEOUT_S
from test.support.recorder import start_publisher, start_recorder, wait_for_data
from test.support.samples import sample_traffic
from test.support.wait import wait_until

TRAFFIC = sample_traffic({GYRO.name: 200, STATIC_READINGS.name: 1})
WRITTEN = [(name, log_time, data) for name, log_time, data, _ in TRAFFIC]
Mount = Callable[..., Path]


def _mount(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["mount", *argv], capture_output=True, text=True, check=False)


@pytest.fixture
def small_fs(tmp_path: Path) -> Iterator[Mount]:
    """Mounts a tmpfs with the given options (``size=256k,nr_inodes=3``); unmounts it (and binds over it) after."""
    mounted: list[Path] = []

    def mount(options: str) -> Path:
        target = tmp_path / f"fs{len(mounted)}"
        target.mkdir()
        done = _mount("-t", "tmpfs", "-o", options, "tmpfs", str(target))
        if done.returncode != 0:
            pytest.skip(f"mount not permitted (needs root or CAP_SYS_ADMIN): {done.stderr.strip()}")
        mounted.append(target)
        return target

    try:
        yield mount
    finally:
        for target in reversed(mounted):  # lazy: also what a bind put over a folder inside
            subprocess.run(["umount", "-l", str(target)], capture_output=True, check=False)


def _read_only(folder: Path) -> None:
    """Make a folder read-only for new opens: a read-only bind of it over itself.

    Linux refuses to remount a filesystem read-only while a file on it is open for writing
    (EBUSY), as the bag's storage file is until close; the file open before keeps writing, and
    what the writer opens afterwards (metadata.yaml, the next storage file) gets EROFS, as on a
    filesystem the kernel remounted read-only after an error. Unmounted with the tmpfs under it.
    """
    for argv in (("--bind", str(folder), str(folder)), ("-o", "remount,ro,bind", str(folder))):
        done = _mount(*argv)
        assert done.returncode == 0, done.stderr


def _fill(fs: Path) -> None:
    """Take every free block of the filesystem (a file grown until ENOSPC)."""
    with (fs / "filler").open("wb", buffering=0) as f:
        try:
            while True:
                f.write(b"\xa5" * 4096)
        except OSError as exc:
            if exc.errno != errno.ENOSPC:
                raise


def _open_writer(bag: Path, **split: float) -> BagWriter:
    writer = BagWriter(bag, compression="none", **split)  # type: ignore[arg-type]
    writer.open()
    for t in TOPICS:
        writer.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
    return writer


def _write(writer: BagWriter, messages: list[tuple[str, int, bytes]]) -> None:
    for name, log_time, data in messages:
        writer.write(name, log_time, data)


def _recovered(bag: Path, out: Path) -> list[tuple[str, int, bytes]]:
    """The messages ``bike-rig bag recover`` gets back from the bag, in log-time order."""
    with open_bag(recover_bag(bag, out).output) as b:
        return [(m.topic, m.log_time, bytes(m.data)) for m in b.messages()]


@pytest.mark.parametrize(("options", "code"), [("size=1m,nr_inodes=3", errno.ENOSPC), ("size=1m", errno.EROFS)])
def test_metadata_yaml_not_written_at_close_raises_and_loses_no_message(
    small_fs: Mount, tmp_path: Path, options: str, code: int
) -> None:
    fs = small_fs(options)  # 3 inodes: the root, the bag folder, its storage file
    bag = fs / "bag"
    writer = _open_writer(bag)
    _write(writer, WRITTEN)
    if code == errno.EROFS:
        _read_only(bag)
    with pytest.raises(OSError, match=os.strerror(code)) as failed:
        writer.close()
    assert failed.value.errno == code
    writer.abort()  # as the recorder does
    assert sorted(p.name for p in bag.iterdir()) == ["bag_0.mcap"]  # no metadata.yaml, no half-written one
    assert scan_mcap(bag / "bag_0.mcap").complete  # summary and footer were written before
    assert _recovered(bag, tmp_path / "recovered") == WRITTEN


@pytest.mark.parametrize("cause", ["space for the closing records", "space for the next file", "inodes", "read-only"])
def test_a_split_that_cannot_be_written_raises_and_loses_no_flushed_message(
    small_fs: Mount, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, cause: str
) -> None:
    fs = small_fs("size=256k,nr_inodes=3" if cause == "inodes" else "size=256k")
    bag = fs / "bag"
    writer = _open_writer(bag, max_duration_s=0.150)
    before, due = WRITTEN[:100], WRITTEN[150]  # log times 1 ms apart: the first 150 fill the first file
    _write(writer, before)
    writer.flush()
    if cause == "space for the closing records":
        _fill(fs)
    elif cause == "space for the next file":  # the first file closes, the second cannot be written
        finish = writer._finish_file

        def finish_then_fill() -> None:
            finish()
            _fill(fs)

        monkeypatch.setattr(writer, "_finish_file", finish_then_fill)
    elif cause == "read-only":
        _read_only(bag)
    code = errno.EROFS if cause == "read-only" else errno.ENOSPC
    with pytest.raises(OSError, match=os.strerror(code)) as failed:
        writer.write(*due)
    assert failed.value.errno == code
    writer.abort()  # as the recorder does: never raises, though the buffered tail cannot be written
    assert [p.name for p in bag.iterdir()] == ["bag_0.mcap"]  # no empty or half-made next file
    assert scan_mcap(bag / "bag_0.mcap").complete == (cause != "space for the closing records")
    assert _recovered(bag, tmp_path / "recovered") == before


def _record(env: dict[str, str], tmp_path: Path, bag: Path, *params: str) -> tuple[int, str, list[str]]:
    """Record gyro batches and the static readings into ``bag``, stop the recorder.

    Without ``params``: 200 gyro batches, all of them recorded. With ``params`` (a split limit):
    gyro batches until the recorder says recording stopped, so the split comes however slowly
    a loaded machine lets the recorder's log time advance.

    Returns:
        The exit status, the log, and its "recording stopped" lines.
    """
    until_stop = bool(params)
    live = {GYRO.name: 0 if until_stop else 200}
    spec = {"early": {STATIC_READINGS.name: 1}, "live": live, "rate_hz": 400.0, "until_stop": until_stop}
    with start_publisher(tmp_path, env, spec) as pub:
        pub.expect("EARLY", STEP_TIMEOUT_S)
        with start_recorder(tmp_path, env, bag, "topics:=[gyro, static_readings]", *params) as rec:
            pub.expect("MATCHED", STEP_TIMEOUT_S)
            pub.send("GO")
            if until_stop:  # a split fails while recording: publish until the recorder says so

                def stopped() -> bool:
                    assert rec.proc.poll() is None, rec.describe()
                    return "recording stopped" in rec.stderr_path.read_text()

                wait_until(stopped, "the recorder to stop recording", STEP_TIMEOUT_S, describe=rec.describe)
                pub.send("STOP")
                pub.expect("PUBLISHED", STEP_TIMEOUT_S)
            else:
                published = json.loads(pub.expect("PUBLISHED", STEP_TIMEOUT_S))
                assert published["counts"][GYRO.name] == 200
                wait_for_data(bag, {GYRO.name: 200, STATIC_READINGS.name: 1}, rec)
            code = rec.stop()
    log = rec.stderr_path.read_text()
    assert "Traceback" not in log, log[-3000:]
    return code, log, [line for line in log.splitlines() if "recording stopped: cannot write" in line]


def _recover(bag: Path, out: Path) -> list[int]:
    """``bike-rig bag recover BAG -o OUT``; the recovered gyro batches' ``first_index``."""
    code, _, err = run_cli("bag", "recover", str(bag), "-o", str(out))
    assert code == 0, err
    with open_bag(out) as b:
        assert b.topics[STATIC_READINGS.name].count == 1
        return [m.first_index for _, _, m in b.decoded([GYRO.name])]


@pytest.mark.ros
def test_the_recorder_out_of_inodes_at_close_stops_in_one_line_and_the_bag_recovers(
    ros_env: dict[str, str], tmp_path: Path, small_fs: Mount
) -> None:
    bag = small_fs("size=4m,nr_inodes=3") / "bag"  # the root, the bag folder, its storage file
    code, log, stopped = _record(node_environment(ros_env), tmp_path, bag)
    assert code == 1, log[-3000:]  # what it could not write is not hidden
    assert len(stopped) == 1, log[-3000:]
    assert "No space left on device (errno 28) after 201 messages" in stopped[0]
    assert stopped[0].endswith(f"'bike-rig bag recover {bag}'; the bag was being closed")
    assert sorted(p.name for p in bag.iterdir()) == ["bag_0.mcap"]
    assert _recover(bag, tmp_path / "recovered") == list(range(200))  # everything


@pytest.mark.ros
def test_the_recorder_out_of_inodes_at_a_split_stops_in_one_line_and_keeps_the_first_file(
    ros_env: dict[str, str], tmp_path: Path, small_fs: Mount
) -> None:
    bag = small_fs("size=4m,nr_inodes=3") / "bag"
    code, log, stopped = _record(node_environment(ros_env), tmp_path, bag, "max_bag_duration:=0.2")
    assert code == 1, log[-3000:]
    assert len(stopped) == 1, log[-3000:]
    assert "No space left on device (errno 28) after " in stopped[0] and "the graph goes on" in stopped[0]
    assert "not recorded after recording stopped" in log and "message not recorded" not in log
    before = int(stopped[0].split(" after ")[1].split()[0])  # messages received before the split
    assert sorted(p.name for p in bag.iterdir()) == ["bag_0.mcap"]
    assert _recover(bag, tmp_path / "recovered") == list(range(before - 1))  # all of them, static readings aside
