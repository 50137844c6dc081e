"""Oversized batches from another process: the fitter rejects them, and its memory stays bounded.

The fitter drops a batch above ``max_batch_samples`` (flag ``oversized_batch``), but the
middleware (Fast DDS) has received it first and keeps a payload buffer of the largest message
it took: the first 2-million-sample batch (16 MB) raises the fitter's RSS once (measured with
10 million samples: +77 MB once, then +0 on a quiet machine). How much of the freed copies the
allocator keeps varies with the threads' timing: on a busy machine the RSS after each of six
batches went +31, +16, +16, +16, +62, +62 MB (a step of three payloads' worth once, then
nothing). So the test sends eight and checks that the RSS stays within five payloads of where
it started: one kept copy per batch would take it past eight.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from test.nodes.test_parameter import node_environment

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parents[2]
SAMPLES = 2_000_000
#: Oversized batches sent.
BATCHES = 8
#: What the fitter logs for each of them.
REJECTED = f"batch of {SAMPLES} samples at index 0 rejected (max_batch_samples 10000)"


def _rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise AssertionError(f"no VmRSS for {pid}")


def _settled_rss(pid: int, wait_s: float = 8.0) -> float:
    """The RSS once it stops moving (two readings 0.5 s apart within 0.5 MB), MB."""
    deadline = time.monotonic() + wait_s
    last = _rss_mb(pid)
    while time.monotonic() < deadline:
        time.sleep(0.5)
        now = _rss_mb(pid)
        if abs(now - last) < 0.5:
            return now
        last = now
    return last


def _rejected(log: Path, count: int, timeout_s: float = 60.0) -> None:
    """Wait until the fitter's log says it rejected ``count`` oversized batches (its callback took them)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if log.read_text().count(REJECTED) >= count:
            return
        time.sleep(0.05)
    raise AssertionError(f"the fitter did not reject batch {count} in {timeout_s} s: {log.read_text()[-2000:]}")


def test_oversized_batches_leave_the_fitters_memory_bounded(ros_env: dict[str, str], tmp_path: Path) -> None:
    env = node_environment(ros_env)
    log = (tmp_path / "fitter.log").open("w")
    fitter = subprocess.Popen([sys.executable, "-m", "bike_rig.nodes.fitter"], cwd=REPO, env=env,
                              stdout=log, stderr=subprocess.STDOUT)  # fmt: skip
    script = str(Path(__file__).with_name("big_batches.py"))
    sender = subprocess.Popen([sys.executable, script, str(SAMPLES), str(BATCHES)],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                              env={**env, "PYTHONPATH": str(REPO)})  # fmt: skip
    try:
        assert sender.stdin is not None and sender.stdout is not None
        assert sender.stdout.readline().strip() == "MATCHED"
        before = _settled_rss(fitter.pid)
        after = []
        for k in range(BATCHES):
            sender.stdin.write("GO\n")
            sender.stdin.flush()
            assert sender.stdout.readline().strip() == "SENT"
            _rejected(tmp_path / "fitter.log", k + 1)  # (measured once taken, not while it is being converted)
            after.append(_settled_rss(fitter.pid))
        assert fitter.poll() is None
    finally:
        sender.kill()
        sender.wait(10)
        fitter.terminate()
        fitter.wait(20)
        log.close()
        for stream in (sender.stdin, sender.stdout):
            if stream is not None:
                stream.close()
    payload = SAMPLES * 8 / 2**20  # MB
    assert all(a - before < 5 * payload for a in after), (before, after)  # a few copies, not one per batch
    text = (tmp_path / "fitter.log").read_text()
    assert text.count(REJECTED) == BATCHES, text[-2000:]
