"""Watch a running graph's nodes: each death said once in one line, the stateless nodes restarted.

A node of a live session may die (a crash, an operator's ``kill``, the out-of-memory killer).
:class:`NodeWatch` turns :meth:`~bike_rig.ros.running.RunningGraph.dead` into one line per death
(the node, how it ended, the last line of its log) and restarts the nodes that lose nothing by
it (:data:`RESTARTABLE`: the fitter, the parameter and the model nodes get their inputs back
from the topics' transient-local history), at most :attr:`NodeWatch.max_restarts` times each.
The driver and the recorder are not restarted: the driver's trial ids and rig time would start
over, and the recorder never writes into an existing bag; the line then says how to go on
(``hint``, e.g. ``bike-rig session --resume FOLDER``).
"""

from __future__ import annotations

import signal
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Protocol

__all__ = ["RESTARTABLE", "NodeWatch", "how_it_ended"]

#: Nodes whose state comes back from the topics' history when they are started again.
RESTARTABLE = frozenset({"fitter", "parameter", "model"})


class WatchedGraph(Protocol):
    """What :class:`NodeWatch` needs of a running graph (:class:`~bike_rig.ros.running.RunningGraph`)."""

    def dead(self) -> list[tuple[str, int, str]]:
        """Nodes that have exited: (name, exit status, last lines of their log)."""
        ...

    def pid(self, name: str) -> int:
        """The process id of node ``name``."""
        ...

    def restart(self, name: str) -> None:
        """Start node ``name`` again."""
        ...


def how_it_ended(code: int) -> str:
    """An exit status in words: ``killed by SIGKILL``, ``exit status 1``."""
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"


@dataclass
class NodeWatch:
    """Say each node death once; restart the restartable nodes (see the module docstring).

    Attributes:
        graph: The running graph.
        hints: What to do when a node that is not restarted dies, by node name ("" none).
        max_restarts: Restarts per node at most; a node that dies more often stays down.
    """

    graph: WatchedGraph
    hints: Mapping[str, str] = field(default_factory=dict)
    max_restarts: int = 3
    restarts: dict[str, int] = field(default_factory=dict)
    _said: set[tuple[str, int]] = field(default_factory=set)

    def __call__(self) -> list[tuple[str, str]]:
        """``(node, line)`` of each death not said yet (restarting what may be restarted)."""
        out = []
        for name, code, tail in self.graph.dead():
            pid = self.graph.pid(name)
            if (name, pid) in self._said:
                continue
            self._said.add((name, pid))
            last = tail.splitlines()[-1].strip() if tail.strip() else "(its log is empty)"
            line = f"node {name} ended ({how_it_ended(code)}); its last log line: {last}"
            done = self.restarts.get(name, 0)
            if name in RESTARTABLE and done < self.max_restarts:
                self.graph.restart(name)
                self.restarts[name] = done + 1
                line += f" — restarted ({done + 1} of {self.max_restarts}): its inputs come back from the topics"
            elif self.hints.get(name):
                line += f" — {self.hints[name]}"
            out.append((name, line))
        return out
