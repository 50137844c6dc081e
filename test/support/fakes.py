"""Stand-ins a test drives by hand: a monotonic clock and a logger that keeps its lines."""

from __future__ import annotations


class ManualClock:
    """A monotonic clock the test moves by hand: calling it gives :attr:`now`, s."""

    def __init__(self, now: float = 0.0) -> None:
        """A clock that reads ``now`` until moved."""
        self.now = now

    def __call__(self) -> float:
        """The time, s."""
        return self.now


class RecordingLog:
    """A logger that keeps each line, ``"I <message>"`` or ``"W <message>"``."""

    def __init__(self) -> None:
        """No line yet."""
        self.lines: list[str] = []

    def info(self, message: str) -> None:
        """Keep an information line."""
        self.lines.append("I " + message)

    def warning(self, message: str) -> None:
        """Keep a warning line."""
        self.lines.append("W " + message)
