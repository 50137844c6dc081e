"""Oversized batches from another process: the fitter rejects them, and its memory stays bounded.

The fitter drops a batch above ``max_batch_samples`` (flag ``oversized_batch``), but the
middleware (Fast DDS) has received it first and keeps a payload buffer of the largest message
it took: the first 2-million-sample batch (16 MB) raises the fitter's RSS once; more of them
reuse that buffer and add nothing (measured with 10 million samples: +77 MB once, then +0).
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


def test_oversized_batches_leave_the_fitters_memory_bounded(ros_env: dict[str, str], tmp_path: Path) -> None:
    env = node_environment(ros_env)
    log = (tmp_path / "fitter.log").open("w")
    fitter = subprocess.Popen([sys.executable, "-m", "bike_rig.nodes.fitter"], cwd=REPO, env=env,
                              stdout=log, stderr=subprocess.STDOUT)  # fmt: skip
    sender = subprocess.Popen([sys.executable, str(Path(__file__).with_name("big_batches.py")), str(SAMPLES), "3"],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                              env={**env, "PYTHONPATH": str(REPO)})  # fmt: skip
    try:
        assert sender.stdin is not None and sender.stdout is not None
        assert sender.stdout.readline().strip() == "MATCHED"
        before = _settled_rss(fitter.pid)
        after = []
        for _ in range(3):
            sender.stdin.write("GO\n")
            sender.stdin.flush()
            assert sender.stdout.readline().strip() == "SENT"
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
    first = after[0] - before
    assert first < 4 * SAMPLES * 8 / 2**20, (before, after)  # the payload once (and a copy), not more
    assert max(after[1:]) - after[0] < 2.0, (before, after)  # the next ones reuse it
    text = (tmp_path / "fitter.log").read_text()
    assert text.count(f"batch of {SAMPLES} samples at index 0 rejected (max_batch_samples 10000)") == 3, text[-2000:]
