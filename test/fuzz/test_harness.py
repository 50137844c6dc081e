"""The fuzz harness's time limit: CPU time, so an endless loop is a hang and a wait is not."""

from __future__ import annotations

import time
from pathlib import Path

from test.fuzz.harness import run_reader


def _endless(_path: Path) -> object:
    n = 0
    while True:
        n += 1


def _waiting(_path: Path) -> object:
    time.sleep(0.5)  # wall time without CPU time: what a busy machine adds to a call
    return None


def test_an_endless_loop_is_a_hang_and_a_wait_is_not(tmp_path: Path) -> None:
    path = tmp_path / "input"
    path.write_bytes(b"")
    hang = run_reader(_endless, path, time_limit_s=0.2, measure_memory=False)
    assert (hang.kind, hang.message) == ("hang", "still running after 0.2 s of CPU time")
    waited = run_reader(_waiting, path, time_limit_s=0.2, measure_memory=False)
    assert waited.kind == "ok" and waited.seconds >= 0.5
