"""NodeWatch: each node death said once in one line; the stateless nodes restarted, a few times at most."""

from __future__ import annotations

import signal
from dataclasses import dataclass, field

from bike_rig.ros.graphwatch import NodeWatch, how_it_ended


@dataclass
class FakeGraph:
    """Nodes by name with a pid; ``die`` ends one, ``restart`` gives it a new pid."""

    pids: dict[str, int] = field(default_factory=lambda: {"driver": 10, "fitter": 11, "recorder": 12})
    ended: dict[str, int] = field(default_factory=dict)
    restarted: list[str] = field(default_factory=list)

    def die(self, name: str, code: int) -> None:
        self.ended[name] = code

    def dead(self) -> list[tuple[str, int, str]]:
        return [(n, c, f"[INFO] starting {n}\n[ERROR] {n} went wrong\n") for n, c in self.ended.items()]

    def pid(self, name: str) -> int:
        return self.pids[name]

    def restart(self, name: str) -> None:
        self.restarted.append(name)
        self.pids[name] += 100
        del self.ended[name]


def test_a_dead_fitter_is_said_once_and_restarted_at_most_max_restarts_times() -> None:
    graph = FakeGraph()
    watch = NodeWatch(graph, max_restarts=2)
    assert watch() == []
    said = []
    for _ in range(3):
        graph.die("fitter", -signal.SIGKILL)
        said += watch()
        assert watch() == []  # once per death
    assert graph.restarted == ["fitter", "fitter"]
    assert [node for node, _ in said] == ["fitter"] * 3
    assert "killed by SIGKILL" in said[0][1] and "[ERROR] fitter went wrong" in said[0][1]
    assert "restarted (1 of 2)" in said[0][1] and "restarted (2 of 2)" in said[1][1]
    assert "restarted" not in said[2][1]  # the third death: it stays down


def test_the_driver_and_recorder_are_not_restarted_and_their_line_says_what_to_do() -> None:
    graph = FakeGraph()
    watch = NodeWatch(graph, hints={"driver": "resume it"})
    graph.die("driver", -signal.SIGKILL)
    graph.die("recorder", 1)
    said = dict(watch())
    assert graph.restarted == []
    assert said["driver"].endswith("— resume it")
    assert "exit status 1" in said["recorder"] and "—" not in said["recorder"]
    assert len(said["driver"].splitlines()) == 1


def test_how_it_ended() -> None:
    assert how_it_ended(-signal.SIGTERM) == "killed by SIGTERM"
    assert how_it_ended(2) == "exit status 2"
    assert how_it_ended(-200) == "killed by signal 200"
