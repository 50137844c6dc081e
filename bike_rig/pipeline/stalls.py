"""Which of the graph's nodes are stalled or behind, seen from outside: ``/diagnostics`` in, one line per change out.

A stalled node (stopped by a debugger, swapping, SIGSTOP) cannot say so itself, so a follower
(``bike-rig run``'s listener, the operator console's link) watches every node's
``/diagnostics`` heartbeat (one array a second) and its ``"<node>: input lag"`` status
(:func:`bike_rig.pipeline.health.input_lag_statuses`). :class:`StallWatch` turns them into one
line per change of a node's standing: silent for :data:`SILENT_S` while its process lives
(``fitter silent for 4 s (stalled?): results will follow``), behind its input
(``fitter 20 s behind: results will follow``), and once it has published without a late input
for a while (:data:`CAUGHT_UP_S`; :data:`RESUMED_S` after a silence) ``fitter caught up``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from enum import Enum

from .diagnostics import INPUT_LAG, Level, Status, node_of

__all__ = ["CAUGHT_UP_S", "NEVER_HEARD_S", "RESUMED_S", "SILENT_S", "StallWatch", "Standing", "StandingChange"]

#: A node whose ``/diagnostics`` heartbeat (1 Hz) has been silent this long is stalled, s.
SILENT_S = 4.0
#: An expected node never heard while its peers have been heard this long is stalled, s (longer
#: than :data:`SILENT_S`: discovery of one publisher may lag another's on a loaded machine).
NEVER_HEARD_S = 10.0
#: A node behind its input has caught up once its arrays have said so for this long (two arrays,
#: not a burst), s.
CAUGHT_UP_S = 0.5
#: A node back from a silence has caught up once its arrays have been on time for this long, s:
#: what it missed while stopped may reach it only at its writers' next heartbeat (3 s), and the
#: first arrays after a stall are published before it has handled its backlog.
RESUMED_S = 3.5


class Standing(Enum):
    """How a node keeps up with its input."""

    OK = "ok"
    BEHIND = "behind"
    SILENT = "silent"


@dataclass(frozen=True)
class StandingChange:
    """A node's standing changed.

    Attributes:
        node: The node.
        standing: Its new standing.
        seconds: Behind: its lag, s; silent: how long it has been silent, s; OK: how long it was
            behind or silent, s.
        text: The line for the operator.
    """

    node: str
    standing: Standing
    seconds: float
    text: str

    @property
    def level(self) -> Level:
        """WARN while behind or silent, OK once caught up."""
        return Level.OK if self.standing is Standing.OK else Level.WARN


@dataclass
class _Node:
    heard_at: float  # when its last array arrived, s (the watch's clock)
    standing: Standing = Standing.OK
    late: bool = False  # its last array's input lag is WARN or worse
    lag_s: float = 0.0  # ... and the lag it gives, s
    on_time_from: float | None = None  # when the arrays in a row without a late input began, s
    since: float = 0.0  # when it fell behind or silent, s
    was_silent: bool = False  # silent since it last caught up


def _lag_of(status: Status) -> float:
    try:
        return float(status.value("lag (s)"))
    except (KeyError, ValueError):
        return math.nan


def _seconds(s: float) -> str:
    return "?" if not math.isfinite(s) else f"{s:.0f}"


class StallWatch:
    """Follows the nodes' heartbeats and input lags (see the module docstring); ROS-free.

    Feed it every array as it arrives (:meth:`heard`), then ask :meth:`check` for the changes.
    A node is followed from its first array on; an ``expected`` node never heard is followed
    from :data:`NEVER_HEARD_S` after the first array of any node (it may have stalled before
    its first heartbeat reached us). One whose process ended (``ended``) or that was restarted
    (:meth:`forget`) is not silent, it is gone.

    Args:
        nodes: The nodes to follow (None: every node heard).
        silent_s: Silence after which a node counts as stalled, s.
        clock: The clock, s (monotonic; tests pass a fake one).
        expected: Nodes that publish a heartbeat and must be heard (a subset of ``nodes``).
    """

    def __init__(
        self,
        nodes: Collection[str] | None = None,
        silent_s: float = SILENT_S,
        clock: Callable[[], float] = time.monotonic,
        expected: Collection[str] = (),
    ) -> None:
        """Follow no node yet."""
        self._only = None if nodes is None else frozenset(nodes)
        self.silent_s = silent_s
        self._clock = clock
        self._nodes: dict[str, _Node] = {}
        self._expected = frozenset(expected)
        self._gone: set[str] = set()
        self._first_heard: float | None = None

    def heard(self, statuses: Sequence[Status]) -> None:
        """One ``/diagnostics`` array arrived now (its statuses, all of one node)."""
        if not statuses:
            return
        node = node_of(statuses[0])
        if self._only is not None and node not in self._only:
            return
        now = self._clock()
        if self._first_heard is None:
            self._first_heard = now
        self._gone.discard(node)
        n = self._nodes.setdefault(node, _Node(now))
        n.heard_at = now
        lag = next((s for s in statuses if s.name == f"{node}: {INPUT_LAG}"), None)
        n.late = lag is not None and lag.level >= Level.WARN
        n.lag_s = _lag_of(lag) if lag is not None else 0.0
        if n.late:
            n.on_time_from = None
        elif n.on_time_from is None:
            n.on_time_from = now

    def forget(self, node: str) -> None:
        """Stop following ``node`` (it ended or was restarted: its next array starts afresh)."""
        self._nodes.pop(node, None)
        self._gone.add(node)

    def _follow_never_heard(self, now: float) -> None:
        """Follow the expected nodes not heard :data:`NEVER_HEARD_S` after the first array."""
        if self._first_heard is None or now - self._first_heard < NEVER_HEARD_S:
            return
        for node in self._expected - self._nodes.keys() - self._gone:
            self._nodes[node] = _Node(self._first_heard)

    def check(self, ended: Collection[str] = ()) -> list[StandingChange]:
        """The nodes whose standing changed since the last call, one change each.

        Args:
            ended: Nodes whose process has ended (forgotten without a line).
        """
        now = self._clock()
        out = []
        for node in [k for k in self._nodes.keys() | self._expected if k in ended]:
            self.forget(node)
        self._follow_never_heard(now)
        for node, n in self._nodes.items():
            silence = now - n.heard_at
            if silence >= self.silent_s:
                target = Standing.SILENT
            elif n.late:
                target = Standing.BEHIND
            elif n.standing is not Standing.OK and not self._on_time_long_enough(n):
                continue  # back, or keeping up again: not for long enough yet
            else:
                target = Standing.OK
            if target is n.standing:
                continue
            if target is Standing.SILENT:
                text, seconds = f"{node} silent for {_seconds(silence)} s (stalled?): results will follow", silence
            elif target is Standing.BEHIND:
                text, seconds = f"{node} {_seconds(n.lag_s)} s behind: results will follow", n.lag_s
            else:
                text, seconds = f"{node} caught up", now - n.since
            if n.standing is Standing.OK:
                n.since = now if target is Standing.BEHIND else n.heard_at
            if target is Standing.SILENT:
                n.on_time_from, n.was_silent = None, True
            else:  # (behind after a silence: its backlog has reached it)
                n.was_silent = False
            n.standing = target
            out.append(StandingChange(node, target, seconds, text))
        return out

    def longest_silence(self) -> float:
        """The longest time since a followed node's last array, s (0 when none is followed)."""
        now = self._clock()
        self._follow_never_heard(now)
        silences = [now - n.heard_at for n in self._nodes.values()]
        if self._first_heard is not None and self._expected - self._nodes.keys() - self._gone:
            silences.append(now - self._first_heard)  # (an expected node not heard yet)
        return max(silences, default=0.0)

    @staticmethod
    def _on_time_long_enough(n: _Node) -> bool:
        """Whether its arrays have had no late input for long enough to have caught up."""
        span = RESUMED_S if n.was_silent else CAUGHT_UP_S
        return n.on_time_from is not None and n.heard_at - n.on_time_from >= span

    def troubled(self) -> dict[str, Standing]:
        """The nodes behind or silent now (as of the last :meth:`check`), with their standing."""
        return {k: n.standing for k, n in self._nodes.items() if n.standing is not Standing.OK}

    def troubles(self) -> list[str]:
        """One phrase per node behind or silent, with its seconds so far.

        ``fitter silent for 12 s``, ``fitter 20 s behind``, or ``fitter catching up after 14 s`` (on
        time again, not for long enough yet).
        """
        now = self._clock()
        out = []
        for node, n in self._nodes.items():
            silent = now - n.heard_at
            if n.standing is Standing.OK:
                continue
            if n.standing is Standing.SILENT and silent >= self.silent_s:
                out.append(f"{node} silent for {_seconds(silent)} s")
            elif n.late:
                out.append(f"{node} {_seconds(n.lag_s)} s behind")
            else:
                out.append(f"{node} catching up after {_seconds(n.heard_at - n.since)} s")
        return out
