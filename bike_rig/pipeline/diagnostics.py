"""Node health as REP-107 statuses, without ROS: plain records in, levels out.

Every node publishes ``diagnostic_msgs/DiagnosticArray`` on ``/diagnostics`` once a second
(:mod:`bike_rig.ros.nodes.diagnostics` does the publishing). Each array holds one
:class:`Status` per concern of the node, named ``"<node>: <concern>"`` (REP-107's
``node: concern`` convention; ``hardware_id`` is ``bike_rig``), with a level, a one-line
message and key-value details (numbers in SI units or as the key says).

This module computes those statuses from the nodes' own counters: the level rules
(:func:`level_above`, :func:`level_below`, :func:`age_level`), a rate meter
(:class:`RateMeter`) that measures events per second of wall time, and a lag meter
(:class:`LagMeter`) that measures how far behind its input a node is. The operator console keeps
the latest statuses in a :class:`HealthBoard` (its compact health line, and which node changed
level).
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from enum import IntEnum

__all__ = [
    "HARDWARE_ID",
    "INPUT_LAG",
    "LAG_WINDOW_S",
    "HealthBoard",
    "LagMeter",
    "Level",
    "RateMeter",
    "Status",
    "StatusReport",
    "age_level",
    "level_above",
    "level_below",
    "node_of",
    "worst",
]

#: ``hardware_id`` of every bike_rig status.
HARDWARE_ID = "bike_rig"
#: The concern of a node's input-lag status (``"<node>: input lag"``).
INPUT_LAG = "input lag"
#: The lag meter reports the largest lag of the messages handled over this last window, s: longer
#: than the 1 s between two ``/diagnostics`` arrays, so that every late message is in one.
LAG_WINDOW_S = 1.5


class Level(IntEnum):
    """REP-107 levels (``diagnostic_msgs/DiagnosticStatus``): OK, WARN, ERROR, STALE."""

    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3


@dataclass(frozen=True)
class Status:
    """One concern of one node.

    Attributes:
        name: ``"<node>: <concern>"``.
        level: Its level.
        message: One line for the operator.
        values: Key-value details, in order (values as text, units in the key).
        hardware_id: What the status is about (``bike_rig``).
    """

    name: str
    level: Level
    message: str
    values: tuple[tuple[str, str], ...] = ()
    hardware_id: str = HARDWARE_ID

    @classmethod
    def of(cls, node: str, concern: str, level: Level, message: str, **values: object) -> Status:
        """A status named ``"<node>: <concern>"``; ``values`` become text (floats with 6 significant digits)."""
        details = tuple((key, _text(v)) for key, v in values.items())
        return cls(f"{node}: {concern}", Level(level), message, details)

    def value(self, key: str) -> str:
        """The detail ``key`` (KeyError when absent)."""
        for k, v in self.values:
            if k == key:
                return v
        raise KeyError(key)


def _text(value: object) -> str:
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def worst(statuses: Iterable[Status]) -> Level:
    """The highest level among ``statuses`` (OK when there are none)."""
    return max((s.level for s in statuses), default=Level.OK)


def level_above(value: float, warn: float, error: float = math.inf) -> Level:
    """OK below ``warn``, WARN from ``warn``, ERROR from ``error`` (a quantity that should stay small)."""
    if value >= error:
        return Level.ERROR
    return Level.WARN if value >= warn else Level.OK


def level_below(value: float, warn: float, error: float = -math.inf) -> Level:
    """OK above ``warn``, WARN at or below it, ERROR at or below ``error`` (a quantity that should stay large)."""
    if value <= error:
        return Level.ERROR
    return Level.WARN if value <= warn else Level.OK


def age_level(age_s: float, warn_s: float, error_s: float) -> Level:
    """The level of something last seen ``age_s`` seconds ago: WARN from ``warn_s``, ERROR from ``error_s``."""
    return level_above(age_s, warn_s, error_s)


class RateMeter:
    """Events per second of wall time over a sliding window.

    Args:
        window_s: The window, s (> 0).
        monotonic: The clock, s (tests pass a fake one).
    """

    def __init__(self, window_s: float = 2.0, monotonic: Callable[[], float] = time.monotonic):
        """Count nothing yet."""
        if not window_s > 0:
            raise ValueError(f"a rate window lasts > 0 s, got {window_s!r}")
        self.window_s = window_s
        self._monotonic = monotonic
        self._events: deque[tuple[float, int]] = deque()
        self._started = monotonic()
        self.total = 0
        self.last_s: float | None = None

    def restart(self) -> None:
        """Forget the events counted so far (not the total nor the last event's time): measure from now."""
        self._events.clear()
        self._started = self._monotonic()

    def add(self, count: int = 1) -> None:
        """``count`` events happened now."""
        now = self._monotonic()
        self._events.append((now, count))
        self.total += count
        self.last_s = now
        self._trim(now)

    def _trim(self, now: float) -> None:
        while self._events and self._events[0][0] < now - self.window_s:
            self._events.popleft()

    def rate(self) -> float:
        """Events per second over the window (over the time since the start while shorter), 1/s."""
        now = self._monotonic()
        self._trim(now)
        span = min(self.window_s, now - self._started)
        if span <= 0:
            return 0.0
        return sum(c for _, c in self._events) / span

    def age(self) -> float:
        """Seconds since the last event (inf before the first), s."""
        return math.inf if self.last_s is None else self._monotonic() - self.last_s


class LagMeter:
    """How far behind its input a node is: now − the source time of each message it handles.

    Fed once per message handled (:meth:`note`, with the message's DDS source timestamp, ns, on
    the host clock that ``clock_ns`` reads). :meth:`lag` is the largest lag of the messages
    handled over the last ``window_s``: a node handling a backlog reads late until it handles
    messages that are recent again, and reads 0 a window after its last late message (caught
    up, or idle: a node that handles nothing is not behind anything it has seen).

    Args:
        window_s: The window, s (> 0).
        clock_ns: The host clock, ns since the epoch (``time.time_ns``; tests pass a fake one).
    """

    def __init__(self, window_s: float = LAG_WINDOW_S, clock_ns: Callable[[], int] = time.time_ns) -> None:
        """Nothing handled yet."""
        if not window_s > 0:
            raise ValueError(f"a lag window lasts > 0 s, got {window_s!r}")
        self._window_ns = int(window_s * 1e9)
        self._clock_ns = clock_ns
        # (handled at, lag), ns: lags strictly decreasing, so the first is the window's largest
        self._late: deque[tuple[int, int]] = deque()
        #: Messages handled since the start (those without a source time not counted).
        self.handled = 0
        #: The largest lag since the start, s.
        self.largest_s = 0.0

    def note(self, source_ns: int | None) -> None:
        """A message with source time ``source_ns`` (ns since the epoch) is handled now; None or ≤ 0: unknown, ignored.

        A source time ahead of this host's clock (another host's clock) counts as no lag.
        """
        if source_ns is None or source_ns <= 0:
            return
        now = self._clock_ns()
        lag = max(0, now - source_ns)
        while self._late and self._late[-1][1] <= lag:
            self._late.pop()
        self._late.append((now, lag))
        self.handled += 1
        self.largest_s = max(self.largest_s, lag / 1e9)

    def lag(self) -> float:
        """The largest lag of the messages handled over the last window, s (0 when none was handled)."""
        horizon = self._clock_ns() - self._window_ns
        while self._late and self._late[0][0] < horizon:
            self._late.popleft()
        return self._late[0][1] / 1e9 if self._late else 0.0


@dataclass(frozen=True)
class StatusReport:
    """One ``DiagnosticArray`` as the console receives it: one node's statuses."""

    statuses: tuple[Status, ...]


def node_of(status: Status) -> str:
    """The node of a status named ``"<node>: <concern>"`` (the whole name without a colon)."""
    return status.name.split(": ", 1)[0]


class HealthBoard:
    """The latest status of every concern of every node, for the operator console.

    :meth:`update` takes one report and says which nodes changed their worst level;
    :meth:`line` is the compact health line (each node's worst level, the reason when not OK).
    A node's :data:`INPUT_LAG` status counts in its level but changes no level by itself in
    :meth:`update`: a node falling behind and catching up is said by
    :class:`bike_rig.pipeline.stalls.StallWatch`, once.
    """

    def __init__(self) -> None:
        """Know no node yet."""
        self.statuses: dict[str, Status] = {}
        self._levels: dict[str, Level] = {}

    def node_level(self, node: str) -> Level:
        """The worst level among ``node``'s statuses."""
        return worst(s for s in self.statuses.values() if node_of(s) == node)

    def worst_status(self, node: str) -> Status | None:
        """``node``'s status of the worst level (the first of those), None for an unknown node."""
        mine = [s for s in self.statuses.values() if node_of(s) == node]
        return max(mine, key=lambda s: s.level, default=None)

    def update(self, statuses: Iterable[Status]) -> list[tuple[str, Level, str]]:
        """Take statuses in; ``(node, level, message)`` of each node whose worst level changed.

        A node first seen OK is not a change (nothing to tell the operator).
        """
        nodes = []
        for s in statuses:
            self.statuses[s.name] = s
            if node_of(s) not in nodes:
                nodes.append(node_of(s))
        out = []
        for node in nodes:
            mine = [s for s in self.statuses.values() if node_of(s) == node and s.name != f"{node}: {INPUT_LAG}"]
            level = worst(mine)
            before = self._levels.get(node, Level.OK)
            self._levels[node] = level
            if level != before:
                status = max(mine, key=lambda s: s.level, default=None)
                reason = "" if status is None else f"{status.name.split(': ', 1)[-1]}: {status.message}"
                out.append((node, level, reason))
        return out

    def line(self, reasons: bool = True, instead: Mapping[str, str] | None = None) -> str:
        """``driver OK · fitter OK · parameter WARN (completeness: incomplete: 3 of 13 periods) · …``; "" if empty.

        Args:
            reasons: Give the reason of each node that is not OK (else the levels only).
            instead: Words that replace a node's level and reason (e.g. ``{"fitter": "SILENT"}``).
        """
        parts = []
        for node in dict.fromkeys(node_of(s) for s in self.statuses.values()):
            if instead and node in instead:
                parts.append(f"{node} {instead[node]}")
                continue
            level = self.node_level(node)
            status = self.worst_status(node)
            reason = ""
            if reasons and level is not Level.OK and status is not None:
                reason = f" ({status.name.split(': ', 1)[-1]}: {status.message})"
            parts.append(f"{node} {level.name}{reason}")
        return " · ".join(parts)
