"""A child process for ROS tests: started under ``timeout``, read line by line, stopped by PID."""

from __future__ import annotations

import contextlib
import os
import queue
import shutil
import signal
import subprocess
import threading
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import IO

# Hard limit for any one child, enforced by coreutils `timeout`: SIGTERM after CHILD_TIMEOUT_S,
# SIGKILL KILL_AFTER_S later. timeout also starts that SIGKILL timer when it passes on our
# SIGINT, so KILL_AFTER_S must exceed stop()'s own grace periods.
CHILD_TIMEOUT_S = 180
KILL_AFTER_S = 30


class RosProcess:
    """A child process whose stdout lines the test waits for, with deadlines.

    The command runs as ``timeout --foreground -k KILL_AFTER_S CHILD_TIMEOUT_S <argv>`` in a session of
    its own (timeout forwards SIGINT and SIGTERM to it). stderr goes to ``<log_dir>/<name>.stderr`` and is shown when an
    expectation fails. Use as a context manager, or call :meth:`stop` in a ``finally``.
    """

    def __init__(
        self,
        name: str,
        argv: Sequence[str],
        env: Mapping[str, str],
        log_dir: Path,
        stdin: bool = False,
    ) -> None:
        self.name = name
        self.stderr_path = log_dir / f"{name}.stderr"
        self.lines: list[str] = []
        self.stop_seconds: float | None = None
        self._queue: queue.Queue[str | None] = queue.Queue()
        timeout = shutil.which("timeout")
        # --foreground: timeout passes a signal to the child once (not to the group as well)
        prefix = [timeout, "--foreground", "-k", str(KILL_AFTER_S), str(CHILD_TIMEOUT_S)] if timeout else []
        self._stderr = self.stderr_path.open("wb")
        self.proc = subprocess.Popen(
            [*prefix, *argv],
            env=dict(env),
            stdin=subprocess.PIPE if stdin else subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=self._stderr,
            text=True,
            bufsize=1,
            start_new_session=True,  # its own process group: the SIGKILL fallback gets all
        )
        self._reader = threading.Thread(target=self._read, name=f"{name}-stdout", daemon=True)
        self._reader.start()

    @property
    def pid(self) -> int:
        """The PID signalled by stop() (that of `timeout`, which passes signals on)."""
        return self.proc.pid

    def _read(self) -> None:
        stdout: IO[str] | None = self.proc.stdout
        assert stdout is not None
        for line in stdout:
            self._queue.put(line.rstrip("\n"))
        self._queue.put(None)

    def describe(self) -> str:
        """The output so far, for assertion messages."""
        stderr = self.stderr_path.read_text(errors="replace")[-4000:]
        return (
            f"--- {self.name} (pid {self.pid}, returncode {self.proc.poll()}, "
            f"stopped in {self.stop_seconds} s) stdout:\n"
            + "\n".join(self.lines[-40:])
            + f"\n--- {self.name} stderr (tail):\n{stderr}"
        )

    def expect(self, word: str, timeout: float) -> str:
        """Wait for the next stdout line starting with word; return the rest of that line.

        Raises:
            AssertionError: On timeout or if the process ends first.
        """
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(f"{self.name}: no {word!r} within {timeout} s\n{self.describe()}")
            try:
                line = self._queue.get(timeout=remaining)
            except queue.Empty:
                continue
            if line is None:
                self._queue.put(None)
                raise AssertionError(f"{self.name} ended before {word!r}\n{self.describe()}")
            self.lines.append(line)
            head, _, rest = line.partition(" ")
            if head == word:
                return rest

    def send(self, line: str) -> None:
        """Write one line to the child's stdin."""
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def stop(self, grace_s: float = 10.0) -> int:
        """Stop the child by PID: SIGINT, then SIGTERM, SIGKILL only as a last resort.

        Safe to call again: then it only returns the exit code.

        Returns:
            The exit code (negative: killed by that signal).
        """
        started = time.monotonic()
        for sig, wait_s in ((signal.SIGINT, grace_s), (signal.SIGTERM, 5.0)):
            if self.proc.poll() is not None:
                break
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.proc.pid, sig)
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.proc.wait(timeout=wait_s)
        if self.proc.poll() is None:
            # last resort, for the whole group (the child of `timeout` too); this leaves
            # Fast DDS shared-memory files behind (see bike_rig.ros.env)
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.proc.pid, signal.SIGKILL)
        code = self.proc.wait()
        if self.stop_seconds is None:
            self.stop_seconds = round(time.monotonic() - started, 3)
        self._reader.join(timeout=5)
        for stream in (self.proc.stdin, self.proc.stdout):
            if stream is not None:
                with contextlib.suppress(OSError):
                    stream.close()
        self._stderr.close()
        return code

    def __enter__(self) -> RosProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
