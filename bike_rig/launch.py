"""The project's own launcher (there is no ``ros2 launch`` wheel).

Start a graph of nodes as separate processes, forward signals, stop them cleanly, and report a
node that died.

A graph file (``format: bike_rig-graph/1``, see ``config/graph.yaml``)::

    format: bike_rig-graph/1
    nodes:                       # started in this order, stopped in reverse
      - name: recorder           # a label for messages
        module: bike_rig.nodes.recorder
        params: recorder.yaml    # a --params-file, relative to the graph file (optional)
        parameters: {output: bag}  # -p NAME:=VALUE overrides (optional)

Every process gets ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and the run's own
``ROS_DOMAIN_ID`` (:mod:`bike_rig.rosenv`).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .core.errors import BikeRigError, InputFileError
from .core.io_yaml import load_yaml_document
from .rosenv import ros_environment

__all__ = ["GRAPH_FORMAT", "Graph", "LaunchError", "NodeSpec", "RunningGraph", "load_graph"]

GRAPH_FORMAT = "bike_rig-graph/1"


class LaunchError(BikeRigError):
    """A node could not be started, or died."""


@dataclass(frozen=True)
class NodeSpec:
    """One node process of a graph.

    Attributes:
        name: Label used in messages (and the log file name).
        module: Python module run with ``python -m``.
        params_file: A ROS parameter file (``--params-file``), or None.
        parameters: ``-p NAME:=VALUE`` overrides.
    """

    name: str
    module: str
    params_file: Path | None = None
    parameters: Mapping[str, object] = field(default_factory=dict)

    def command(self) -> list[str]:
        """The command line of the node process."""
        cmd = [sys.executable, "-m", self.module, "--ros-args"]
        if self.params_file is not None:
            cmd += ["--params-file", str(self.params_file)]
        for key, value in self.parameters.items():
            cmd += ["-p", f"{key}:={_ros_value(value)}"]
        return cmd


def _ros_value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, (list, tuple)):
        return json.dumps(list(value))
    text = str(value)
    # a string parameter that would parse as YAML number/bool must be quoted
    return json.dumps(text) if text.strip() == "" or _looks_typed(text) else text


def _looks_typed(text: str) -> bool:
    if text.lower() in {"true", "false", "yes", "no", "on", "off", "null", "~"}:
        return True
    try:
        float(text)
    except ValueError:
        return False
    return True


@dataclass(frozen=True)
class Graph:
    """The nodes of a graph, in start order."""

    nodes: tuple[NodeSpec, ...]
    path: str = "<memory>"

    def with_parameters(self, overrides: Mapping[str, Mapping[str, object]]) -> Graph:
        """A copy with extra ``-p`` overrides per node name."""
        known = {n.name for n in self.nodes}
        for name in overrides:
            if name not in known:
                raise LaunchError(f"{self.path}: no node named '{name}' (nodes: {', '.join(sorted(known))})")
        nodes = tuple(
            NodeSpec(n.name, n.module, n.params_file, {**n.parameters, **overrides.get(n.name, {})}) for n in self.nodes
        )
        return Graph(nodes, self.path)


def load_graph(path: str | Path) -> Graph:
    """Read a ``bike_rig-graph/1`` file.

    Raises:
        InputFileError: unreadable, wrong format, or a node entry is malformed.
    """
    p = str(path)
    data, lines = load_yaml_document(path)
    if not isinstance(data, dict) or data.get("format") != GRAPH_FORMAT:
        raise InputFileError(p, f"not a graph file: expected 'format: {GRAPH_FORMAT}'")
    entries = data.get("nodes")
    if not isinstance(entries, list) or not entries:
        raise InputFileError(p, "needs a non-empty list 'nodes'", key="nodes", line=lines.get(("nodes",)))
    base = Path(path).parent
    nodes = []
    for i, e in enumerate(entries):
        where = f"nodes[{i}]"
        line = lines.get(("nodes", i))
        if not isinstance(e, dict) or not isinstance(e.get("name"), str) or not isinstance(e.get("module"), str):
            raise InputFileError(p, "each node needs 'name' and 'module' strings", key=where, line=line)
        unknown = set(e) - {"name", "module", "params", "parameters"}
        if unknown:
            raise InputFileError(p, f"unknown key(s) {', '.join(sorted(unknown))}", key=where, line=line)
        params_file = None
        if e.get("params") is not None:
            params_file = (base / str(e["params"])).resolve()
            if not params_file.is_file():
                raise InputFileError(p, f"parameter file {params_file} not found", key=f"{where}.params", line=line)
        parameters = e.get("parameters") or {}
        if not isinstance(parameters, dict):
            raise InputFileError(p, "'parameters' must be a mapping", key=f"{where}.parameters", line=line)
        nodes.append(NodeSpec(e["name"], e["module"], params_file, parameters))
    names = [n.name for n in nodes]
    if len(set(names)) != len(names):
        raise InputFileError(p, "node names must be unique", key="nodes", line=lines.get(("nodes",)))
    return Graph(tuple(nodes), p)


@dataclass
class _Process:
    spec: NodeSpec
    popen: subprocess.Popen[bytes]
    log: Path


class RunningGraph:
    """The processes of a started graph; a context manager that always stops them.

    Args:
        graph: What to start.
        log_dir: Where each node's stdout/stderr go (``<name>.log``).
        domain_id: The run's ROS_DOMAIN_ID (default: allocated by :mod:`bike_rig.rosenv`).
        env: Extra environment for every node.
    """

    def __init__(
        self,
        graph: Graph,
        log_dir: Path,
        domain_id: int | None = None,
        env: Mapping[str, str] | None = None,
    ) -> None:
        """Keep the graph and log directory and build the nodes' environment; nothing is started yet."""
        self.graph = graph
        self.log_dir = log_dir
        base = dict(os.environ)
        base.update(env or {})
        self.env = ros_environment(base, domain_id=domain_id)
        self.processes: list[_Process] = []

    @property
    def domain_id(self) -> int:
        """The ROS_DOMAIN_ID every node of the run uses."""
        return int(self.env["ROS_DOMAIN_ID"])

    def start(self) -> RunningGraph:
        """Start every node (each in its own process group)."""
        self.log_dir.mkdir(parents=True, exist_ok=True)
        for spec in self.graph.nodes:
            log = self.log_dir / f"{spec.name}.log"
            with log.open("wb") as out:
                popen = subprocess.Popen(
                    spec.command(),
                    stdout=out,
                    stderr=subprocess.STDOUT,
                    stdin=subprocess.DEVNULL,
                    env=self.env,
                    start_new_session=True,
                )
            self.processes.append(_Process(spec, popen, log))
        return self

    def __enter__(self) -> RunningGraph:
        """Start every node (:meth:`start`) and return the running graph."""
        return self.start()

    def __exit__(self, *exc: object) -> None:
        """Stop every node, however the block ended."""
        self.stop()

    def dead(self) -> list[tuple[str, int, str]]:
        """Nodes that have exited: (name, exit status, last lines of their log)."""
        out = []
        for p in self.processes:
            code = p.popen.poll()
            if code is not None:
                out.append((p.spec.name, code, _tail(p.log)))
        return out

    def pid(self, name: str) -> int:
        """The process id of node ``name``."""
        return next(p.popen.pid for p in self.processes if p.spec.name == name)

    def restart(self, name: str) -> None:
        """Start node ``name`` again (after it died or was killed)."""
        for i, p in enumerate(self.processes):
            if p.spec.name == name:
                if p.popen.poll() is None:
                    raise LaunchError(f"node '{name}' is still running (pid {p.popen.pid})")
                with p.log.open("ab") as out:
                    popen = subprocess.Popen(
                        p.spec.command(),
                        stdout=out,
                        stderr=subprocess.STDOUT,
                        stdin=subprocess.DEVNULL,
                        env=self.env,
                        start_new_session=True,
                    )
                self.processes[i] = _Process(p.spec, popen, p.log)
                return
        raise LaunchError(f"no node named '{name}'")

    def stop(self, timeout_s: float = 15.0) -> dict[str, int]:
        """Stop every node in reverse start order: SIGINT, then SIGTERM, then SIGKILL.

        Returns:
            Exit status per node name.
        """
        status: dict[str, int] = {}
        for p in reversed(self.processes):
            status[p.spec.name] = _stop(p.popen, timeout_s)
        return status


def _stop(popen: subprocess.Popen[bytes], timeout_s: float) -> int:
    for sig, wait in ((signal.SIGINT, timeout_s), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
        if popen.poll() is not None:
            break
        try:
            popen.send_signal(sig)
        except ProcessLookupError:
            break
        try:
            popen.wait(wait)
        except subprocess.TimeoutExpired:
            continue
    return popen.wait()


def _tail(path: Path, lines: int = 5) -> str:
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError:
        return ""


def run_graph(graph: Graph, log_dir: Path, domain_id: int | None = None, poll_s: float = 0.2) -> int:
    """Run ``graph`` until SIGINT/SIGTERM or until a node dies; stop everything cleanly.

    Returns:
        0 after a requested stop with every node exiting cleanly, 1 if a node died or failed
        to stop cleanly.
    """
    requested = {"stop": False}

    def on_signal(signum: int, _frame: Any) -> None:
        requested["stop"] = True

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    died: list[tuple[str, int, str]] = []
    try:
        with RunningGraph(graph, log_dir, domain_id) as running:
            print(
                f"bike-rig run: {len(graph.nodes)} nodes on ROS_DOMAIN_ID={running.domain_id} (localhost), logs in "
                f"{log_dir}",
                file=sys.stderr,
            )
            while not requested["stop"]:
                died = running.dead()
                if died:
                    break
                time.sleep(poll_s)
            status = running.stop()
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
    for name, code, tail in died:
        print(f"bike-rig run: node '{name}' died with status {code}; last log lines:\n{tail}", file=sys.stderr)
    unclean = {n: c for n, c in status.items() if c not in (0, -signal.SIGINT)}
    if unclean and not died:
        print(f"bike-rig run: nodes that did not stop cleanly: {unclean}", file=sys.stderr)
    return 1 if died or unclean else 0


def parse_overrides(items: Sequence[str]) -> dict[str, dict[str, object]]:
    """``NODE.NAME=VALUE`` strings → ``{node: {name: value}}`` (values parsed as YAML scalars)."""
    import yaml

    out: dict[str, dict[str, object]] = {}
    for item in items:
        key, sep, value = item.partition("=")
        node, dot, name = key.partition(".")
        if not sep or not dot or not node or not name:
            raise LaunchError(f"--param expects NODE.NAME=VALUE, got '{item}'")
        out.setdefault(node, {})[name] = yaml.safe_load(value) if value else ""
    return out
