"""Plain mode: one command per line from a stream, one reply per line (text or JSON lines).

For scripts and automated rigs (``bike-rig session --plain [--json]``): the controller's
commands (:mod:`bike_rig.session.controller`) plus ``wait [SECONDS]`` (until the last started
trial has its result and a resumed session's trials are back) and ``wait complete [SECONDS]``
(until the set is complete with its speeds and nothing new came for :data:`QUIET_S`), at most
SECONDS (default 600) of wall time, else ``error``. What the graph publishes is written as it
arrives; end of input is ``quit``.
"""

from __future__ import annotations

import json
import queue
import threading
import time
from collections.abc import Callable
from typing import IO

from .controller import Reply, SessionController

__all__ = ["POLL_S", "QUIET_S", "run_plain"]

#: How often the graph is polled while waiting for input, s.
POLL_S = 0.02
#: ``wait complete``: how long the parameter set and speeds must stay unchanged, s.
QUIET_S = 0.5


def _reader(stream: IO[str], lines: queue.Queue[str | None]) -> None:
    for line in stream:
        lines.put(line)
    lines.put(None)


class _Writer:
    def __init__(self, out: IO[str], as_json: bool) -> None:
        self.out, self.as_json = out, as_json

    def __call__(self, replies: list[Reply]) -> None:
        for r in replies:
            self.out.write((json.dumps(r.as_json(), allow_nan=True) if self.as_json else _text(r)) + "\n")
        if replies:
            self.out.flush()


def _text(r: Reply) -> str:
    prefix = {"error": "error: ", "warning": "warning: "}.get(r.kind, "")
    return prefix + r.text


def _wait(ctl: SessionController, args: list[str], write: Callable[[list[Reply]], None]) -> None:
    complete = bool(args) and args[0] == "complete"
    rest = args[1:] if complete else args
    try:
        limit = float(rest[0]) if rest else 600.0
    except ValueError:
        write([Reply("error", f"wait: '{rest[0]}' is not a number of seconds")])
        return
    started = [t for t in ctl.session.trials.values()]
    last = started[-1] if started else None
    deadline = time.monotonic() + limit
    while time.monotonic() < deadline:
        write(ctl.pump())
        s = ctl.session
        settled = ctl.clock() - ctl.updated_at >= QUIET_S
        if complete and s.complete and s.stability is not None and not s.unaccounted() and settled:
            return
        if not complete and ctl.resumed and (last is None or last.fit is not None or last.aborted):
            return
        time.sleep(POLL_S)
    what = "the parameter set" if complete else f"trial {last.trial_id}" if last else "the recorded trials"
    write([Reply("error", f"wait: {what} not finished after {limit:g} s")])


def run_plain(ctl: SessionController, stdin: IO[str], stdout: IO[str], as_json: bool = False) -> int:
    """Read commands from ``stdin`` until ``quit`` or its end; replies to ``stdout``.

    Returns:
        0, or 1 when a command failed (the session still went on).
    """
    write = _Writer(stdout, as_json)
    lines: queue.Queue[str | None] = queue.Queue()
    threading.Thread(target=_reader, args=(stdin, lines), daemon=True).start()
    failed = False
    while not ctl.quit_requested:
        write(ctl.pump())
        try:
            line = lines.get(timeout=POLL_S)
        except queue.Empty:
            continue
        if line is None:
            line = "quit"
        words = line.split()
        if words and words[0].lower() == "wait":
            _wait(ctl, words[1:], write)
            continue
        replies = ctl.execute(line)
        failed |= any(r.kind == "error" for r in replies)
        write(replies)
    write(ctl.pump())
    return 1 if failed else 0
