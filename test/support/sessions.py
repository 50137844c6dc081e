"""Clean-up of what a ``bike-rig session`` started: its processes, by the PIDs it wrote."""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Any

from bike_rig.core.measurements import Reading
from bike_rig.session.plan import ReadingItem, SessionPlan

__all__ = ["PlainSession", "kill_session", "plan_script", "session_pids", "wait_gone"]


def plan_script(plan: SessionPlan, readings: Mapping[str, Reading]) -> list[str]:
    """The plan in order as plain-mode commands: readings typed (value and σ exactly), trials started and awaited."""
    script: list[str] = []
    for item in plan.items:
        if isinstance(item, ReadingItem):
            r = readings[item.key]
            script.append(f"reading {item.key} {r.value!r} {r.sigma!r}")
        else:
            script += [f"start {item.item_id}", "wait 60"]
    return script


def session_pids(folder: Path) -> dict[str, int]:
    """The PIDs ``bike-rig session`` wrote to ``<folder>/logs/pids``: the console and each node."""
    path = folder / "logs" / "pids"
    if not path.is_file():
        return {}
    return {name: int(pid) for name, pid in (line.split() for line in path.read_text().splitlines() if line)}


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def wait_gone(pids: dict[str, int], timeout_s: float) -> list[str]:
    """Wait up to ``timeout_s`` for the processes to end; the names of those still running."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        alive = [name for name, pid in pids.items() if _alive(pid)]
        if not alive:
            return []
        time.sleep(0.1)
    return [name for name, pid in pids.items() if _alive(pid)]


def _ours(pid: int) -> bool:
    """Whether ``pid`` still runs a bike_rig program (not a process that reused the number)."""
    try:
        return b"bike" in Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return False


def kill_session(folder: Path) -> None:
    """SIGKILL every process of the session in ``folder`` that still runs (after a failed test)."""
    for pid in session_pids(folder).values():
        if not _ours(pid):
            continue
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass


def end_process(proc: subprocess.Popen[str]) -> None:
    """SIGKILL a helper process the test started, reap it, and close its pipes."""
    proc.kill()
    proc.wait(10)
    for stream in (proc.stdin, proc.stdout):
        if stream is not None:
            stream.close()


class PlainSession:
    """A plain --json session driven line by line."""

    def __init__(self, argv: list[str], env: dict[str, str]) -> None:
        self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
        self.replies: queue.Queue[dict[str, Any]] = queue.Queue()
        self.seen: list[dict[str, Any]] = []
        assert self.proc.stdout is not None
        threading.Thread(target=self._read, args=(self.proc.stdout,), daemon=True).start()

    def _read(self, stream: IO[str]) -> None:
        for line in stream:
            self.replies.put(json.loads(line))

    def send(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def until(self, what: Any, timeout_s: float = 60) -> dict[str, Any]:
        """The first reply from now on for which ``what(reply)`` holds."""
        while True:
            reply = self.replies.get(timeout=timeout_s)
            self.seen.append(reply)
            if what(reply):
                return reply

    def trial(self, item: str) -> dict[str, Any]:
        """Start ``item``; its result."""
        self.send(f"start {item}")
        started = self.until(lambda r: r.get("command") == "start")
        assert started["kind"] == "ok", started
        return self.until(lambda r: r["kind"] == "result" and r.get("trial_id") == started["trial_id"])

    def close(self) -> None:
        end_process(self.proc)
