"""The launcher: graph files, environment of every node, signals, dead nodes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bike_rig.core.errors import InputFileError
from bike_rig.ros.launch import Graph, LaunchError, NodeSpec, load_graph, parse_overrides
from bike_rig.ros.running import RunningGraph
from test.support.wait import WAIT_TIMEOUT_S, wait_until

REPO = Path(__file__).resolve().parents[2]


def _env(tmp_path: Path) -> dict[str, str]:
    return {"FAKE_NODE_OUT": str(tmp_path), "PYTHONPATH": str(REPO)}


def _reports(tmp_path: Path, n: int, timeout_s: float = WAIT_TIMEOUT_S) -> list[dict[str, object]]:
    files = wait_until(
        lambda: (fs := sorted(tmp_path.glob("*.json")))[n - 1 :] and fs,
        f"{n} fake nodes' reports",
        timeout_s,
        0.02,
        lambda: f"{len(list(tmp_path.glob('*.json')))} reported",
    )
    # (each report appears whole: the fake node renames it into place)
    return [json.loads(f.read_text()) for f in files]


def _running(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie that no one has reaped yet has ended)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def test_nodes_get_localhost_and_the_runs_domain_id(tmp_path: Path) -> None:
    graph = Graph(
        (
            NodeSpec("a", "test.nodes.fake_node", None, {"rate": 5.0, "name": "x y"}),
            NodeSpec("b", "test.nodes.fake_node"),
        )
    )
    with RunningGraph(graph, tmp_path / "logs", domain_id=57, env=_env(tmp_path)) as running:
        reports = _reports(tmp_path, 2)
        assert running.dead() == []
        status = running.stop()
    assert status == {"a": 0, "b": 0}
    for r in reports:
        assert r["env"] == {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_DOMAIN_ID": "57"}
    args = next(r["args"] for r in reports if "-p" in r["args"])
    assert args == ["--ros-args", "-p", "rate:=5.0", "-p", "name:=x y"]


def test_a_dead_node_is_reported(tmp_path: Path) -> None:
    graph = Graph((NodeSpec("ok", "test.nodes.fake_node"), NodeSpec("bad", "test.nodes.no_such_module")))
    with RunningGraph(graph, tmp_path / "logs", env=_env(tmp_path)) as running:
        dead = wait_until(running.dead, "a dead node")
    assert [(name, code) for name, code, _ in dead] == [("bad", 1)]
    assert "No module named test.nodes.no_such_module" in dead[0][2]


def test_restart_after_kill(tmp_path: Path) -> None:
    graph = Graph((NodeSpec("a", "test.nodes.fake_node"),))
    with RunningGraph(graph, tmp_path / "logs", env=_env(tmp_path)) as running:
        first = _reports(tmp_path, 1)
        import os
        import signal

        os.kill(running.pid("a"), signal.SIGKILL)
        wait_until(running.dead, "the killed node", interval_s=0.02)
        running.restart("a")
        second = _reports(tmp_path, 2)
    assert len(first) == 1 and len(second) == 2


def test_a_node_is_found_by_name_or_refused(tmp_path: Path) -> None:
    graph = Graph((NodeSpec("a", "test.nodes.fake_node"),))
    with RunningGraph(graph, tmp_path / "logs", env=_env(tmp_path)) as running:
        assert running.log("a") == running.processes[0].log
        with pytest.raises(LaunchError, match=r"^node 'a' is still running \(pid \d+\)$"):
            running.restart("a")
        for method in (running.restart, running.stop_node, running.interrupt, running.log):
            with pytest.raises(LaunchError, match="^no node named 'b'$"):
                method("b")


def test_graph_file_and_errors(tmp_path: Path) -> None:
    (tmp_path / "p.yaml").write_text("a:\n  ros__parameters: {}\n")
    good = tmp_path / "graph.yaml"
    good.write_text(
        "format: bike_rig-graph/1\nnodes:\n  - {name: a, module: test.nodes.fake_node, params: p.yaml}\n"
        "  - {name: b, module: test.nodes.fake_node, parameters: {x: 1}}\n"
    )
    g = load_graph(good)
    assert [n.name for n in g.nodes] == ["a", "b"]
    assert g.nodes[0].params_file == (tmp_path / "p.yaml").resolve()
    assert g.with_parameters({"b": {"y": "2"}}).nodes[1].parameters == {"x": 1, "y": "2"}
    with pytest.raises(LaunchError, match="no node named 'c'"):
        g.with_parameters({"c": {}})
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: bike_rig-graph/1\nnodes:\n  - {name: a, module: m, params: missing.yaml}\n")
    with pytest.raises(InputFileError, match="missing.yaml not found") as err:
        load_graph(bad)
    assert err.value.line == 3
    assert parse_overrides(["driver.time_scale=20", "driver.session=a.yaml"]) == {
        "driver": {"time_scale": 20, "session": "a.yaml"}
    }
    with pytest.raises(LaunchError, match="NODE.NAME=VALUE"):
        parse_overrides(["oops"])


def test_string_parameters_that_look_like_numbers_are_quoted() -> None:
    cmd = NodeSpec("a", "m", None, {"s": "5", "t": True, "u": "true"}).command()
    assert cmd[-6:] == ["-p", 's:="5"', "-p", "t:=true", "-p", 'u:="true"']


def test_the_nodes_end_with_their_launcher_however_it_dies(tmp_path: Path) -> None:
    """A SIGKILLed launcher (a console, ``bike-rig run``) leaves no node running: each gets SIGTERM."""
    import os
    import signal
    import subprocess
    import sys

    launcher = (
        "import sys, time\n"
        "from pathlib import Path\n"
        "from bike_rig.ros.launch import Graph, NodeSpec\n"
        "from bike_rig.ros.running import RunningGraph\n"
        "g = Graph((NodeSpec('a', 'test.nodes.fake_node'), NodeSpec('b', 'test.nodes.fake_node')))\n"
        f"RunningGraph(g, Path({str(tmp_path / 'logs')!r}), env={_env(tmp_path)!r}).start()\n"
        "print('started', flush=True)\n"
        "time.sleep(600)\n"
    )
    with subprocess.Popen(
        [sys.executable, "-c", launcher],
        stdout=subprocess.PIPE,
        text=True,
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    ) as proc:
        try:
            assert proc.stdout is not None and proc.stdout.readline() == "started\n"
            reports = _reports(tmp_path, 2)
            pids = [int(f.stem) for f in sorted(tmp_path.glob("*.json"))]
            assert len(reports) == len(pids) == 2
            proc.send_signal(signal.SIGKILL)
            proc.wait(10)
            wait_until(
                lambda: not any(_running(p) for p in pids),
                "the orphaned nodes to end",
                describe=lambda: f"running: {[p for p in pids if _running(p)]}",
            )
        finally:
            for f in tmp_path.glob("*.json"):
                try:
                    os.kill(int(f.stem), signal.SIGKILL)
                except ProcessLookupError:
                    pass


def test_a_subset_keeps_the_start_order_and_refuses_unknown_or_empty(tmp_path: Path) -> None:
    graph = Graph(tuple(NodeSpec(n, "test.nodes.fake_node") for n in ("recorder", "fitter", "driver")), "g.yaml")
    assert [n.name for n in graph.subset(only=["driver"]).nodes] == ["driver"]
    assert [n.name for n in graph.subset(without=["driver"]).nodes] == ["recorder", "fitter"]
    assert [n.name for n in graph.subset(only=["driver", "recorder"]).nodes] == ["recorder", "driver"]
    with pytest.raises(LaunchError, match=r"^g\.yaml: no node named 'drivr' \(nodes: recorder, fitter, driver\)$"):
        graph.subset(without=["drivr"])
    with pytest.raises(LaunchError, match=r"^g\.yaml: no node left to start"):
        graph.subset(only=["driver"], without=["driver"])
