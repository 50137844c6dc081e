"""Drive a terminal program as a person does: under tmux, with send-keys and capture-pane.

Each :class:`TmuxSession` uses its own tmux server (``-L <socket>``), so tests never touch a
user's tmux, and kills that server (by the PID tmux reports) when closed.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

from test.support.wait import wait_until

__all__ = ["TMUX", "TmuxSession", "flatten"]

TMUX = shutil.which("tmux") or "/usr/bin/tmux"
#: What a row may end with besides its text: spaces and a scroll bar's block glyphs.
_SCROLLBAR = " ▁▂▃▄▅▆▇█▏▎▍▌▋▊▉▔▕"


def flatten(screen: str) -> str:
    """The screen's rows joined by spaces, each right-stripped of spaces and scroll-bar glyphs."""
    return " ".join(row.rstrip(_SCROLLBAR) for row in screen.splitlines())


class TmuxSession:
    """One program in a detached tmux window of ``width`` × ``height``.

    Args:
        argv: The program and its arguments.
        env: Its environment.
        cwd: Its working directory.
        width: Terminal columns.
        height: Terminal rows.
    """

    def __init__(
        self, argv: Sequence[str], env: Mapping[str, str], cwd: Path, width: int = 80, height: int = 24
    ) -> None:
        """Start ``argv`` in a new tmux server and session."""
        self.socket = f"bike_rig_test_{os.getpid()}_{time.monotonic_ns()}"
        self.env = dict(env)
        self.env.pop("TMUX", None)
        for size in ("COLUMNS", "LINES"):  # (pytest-xdist's workers set 80×24: the pane's own size counts)
            self.env.pop(size, None)
        self.env["TERM"] = "xterm-256color"
        # the pane stays after the program exits, so its last screen and status can be read
        script = f'{shlex.join(argv)}; echo "[exit $?]"; sleep 600'
        self._tmux("new-session", "-d", "-s", "t", "-x", str(width), "-y", str(height), "-c", str(cwd), script)
        self._tmux("set-option", "-t", "t", "remain-on-exit", "on")

    def _tmux(self, *args: str) -> str:
        done = subprocess.run(
            [TMUX, "-L", self.socket, *args], env=self.env, capture_output=True, text=True, timeout=20, check=True
        )
        return done.stdout

    def keys(self, *keys: str) -> None:
        """Press keys (tmux key names: ``F2``, ``Enter``, ``C-c``...)."""
        self._tmux("send-keys", "-t", "t", *keys)

    def type(self, text: str) -> None:
        """Type ``text`` literally (no Enter)."""
        self._tmux("send-keys", "-t", "t", "-l", "--", text)

    def screen(self) -> str:
        """The visible screen, one line per row."""
        return self._tmux("capture-pane", "-t", "t", "-p")

    def wait_for(self, pattern: str, timeout_s: float = 30.0, flat: bool = False) -> str:
        """Wait until the screen matches ``pattern`` (a regex); the screen.

        With ``flat`` the screen's rows are joined by spaces first (right-stripped of spaces
        and scroll-bar glyphs), so that a line the program wrapped still matches (match any whitespace between words).

        Raises:
            AssertionError: Not within ``timeout_s`` (with the last screen).
        """
        last = [""]

        def matched() -> bool:
            last[0] = self.screen()
            return re.search(pattern, flatten(last[0]) if flat else last[0]) is not None

        wait_until(matched, f"the screen to match {pattern!r}", timeout_s, describe=lambda: f"last screen:\n{last[0]}")
        return last[0]

    def close(self) -> None:
        """Kill the tmux server and everything in it."""
        try:
            pid = int(self._tmux("display-message", "-p", "-t", "t", "#{pid}").strip() or 0)
        except (subprocess.SubprocessError, ValueError):
            pid = 0
        subprocess.run([TMUX, "-L", self.socket, "kill-server"], env=self.env, capture_output=True, timeout=20)
        if pid:
            try:
                os.kill(pid, 9)
            except ProcessLookupError:
                pass
