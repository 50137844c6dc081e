"""Stopping a graph loses nothing a node still holds: the recorder syncs before the others stop.

A node's transient-local history lives with its process. On a loaded machine the recorder may
not have matched a publisher yet when the launcher stops the graph (a fast two-host run once
lost every period estimate so). :meth:`RunningGraph.sync_recorder` has the recorder match every
running node's publishers and take what they hold first.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from bike_rig.bag.reader import open_bag
from bike_rig.config.topics import PERIODS
from bike_rig.ros.launch import Graph, NodeSpec
from bike_rig.ros.running import RECORDER_MODULE, RunningGraph
from test.support.wait import wait_until

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parents[2]


def _logged(path: Path, text: str) -> bool:
    return path.is_file() and text in path.read_text(errors="replace")


def test_a_message_published_just_before_the_stop_is_recorded(tmp_path: Path, ros_env: dict[str, str]) -> None:
    bag = tmp_path / "bag"
    graph = Graph(
        (
            NodeSpec("recorder", RECORDER_MODULE, parameters={"output": str(bag)}),
            NodeSpec("late", "test.bag.late_publisher"),
        )
    )
    env = {**ros_env, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    running = RunningGraph(graph, tmp_path / "logs", env=env).start()
    try:
        recorder_log, late_log = running.log("recorder"), running.log("late")
        wait_until(lambda: _logged(recorder_log, "recording ") and _logged(late_log, "PUBLISHED"), "both nodes up")
        status = running.stop()  # at once: the recorder may not have matched "late" yet
    finally:
        running.stop()
    assert status == {"late": 0, "recorder": 0}, status
    log = recorder_log.read_text()
    with open_bag(bag) as reader:
        periods = list(reader.messages([PERIODS.name]))
    assert len(periods) == 1, log
    assert "synced: every publisher matched" in log, log
    assert not (tmp_path / "logs" / "recorder.sync").exists()
