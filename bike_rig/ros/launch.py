"""The project's own launcher (there is no ``ros2 launch`` wheel).

A graph of nodes, each run as its own process: read (:func:`load_graph`) and checked here,
started, stopped and watched by :class:`bike_rig.ros.running.RunningGraph`.

A graph file (``format: bike_rig-graph/1``, see ``config/graph.yaml``)::

    format: bike_rig-graph/1
    nodes:                       # started in this order, stopped in reverse
      - name: recorder           # a label for messages
        module: bike_rig.ros.nodes.recorder
        params: recorder.yaml    # a --params-file, relative to the graph file (optional)
        parameters: {output: bag}  # -p NAME:=VALUE overrides (optional)

Every process gets ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and the run's own
``ROS_DOMAIN_ID`` (:mod:`bike_rig.ros.env`), and ``ROS_STATIC_PEERS`` only when the graph is
split over two hosts (:meth:`Graph.subset`, ``static_peers``).

Before anything starts, :meth:`Graph.checked` (called by :meth:`~bike_rig.ros.running.RunningGraph.start`) checks
every ``-p`` override of a bike_rig node against the parameters the node declares
(:func:`bike_rig.ros.nodes.settings.node_parameter_specs`): an unknown name, or a value of the wrong
type or out of range, is a one-line :class:`LaunchError` naming the node's parameters; an
integer given for a double becomes a double. It also makes the file parameters
(:data:`PATH_PARAMETERS`) absolute, so that every node reads the same files whatever its
working directory: a relative path is taken from the current directory when it exists there,
else from the parameter file's folder (a value written in one), else from the config folder
(:func:`bike_rig.config.paths.config_dir`, e.g. ``bicycles/browser.yaml``). A file given as an override
that exists in none of them is an error; an output (the recorder's bag) must not exist yet.
"""

from __future__ import annotations

import difflib
import json
import os
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from ..config.paths import config_dir
from ..config.settings import ParamValueError, parameter_message
from ..core.errors import BikeRigError, InputFileError, one_line, short_repr
from ..core.io_yaml import load_yaml_document

if TYPE_CHECKING:
    from ..config.settings import ParamSpec

__all__ = [
    "ALTERNATIVES",
    "GRAPH_FORMAT",
    "PATH_PARAMETERS",
    "Graph",
    "LaunchError",
    "NodeSpec",
    "load_graph",
    "parse_overrides",
]

GRAPH_FORMAT = "bike_rig-graph/1"

#: The node parameters that name files, per node module: ``input`` (a file or folder that is
#: read) or ``output`` (one the node creates). :meth:`Graph.checked` makes them absolute.
PATH_PARAMETERS: Mapping[str, Mapping[str, str]] = {
    "bike_rig.ros.nodes.driver": {
        "session": "input",
        "bicycle": "input",
        "rig": "input",
        "bag": "input",
        "resume": "input",
    },
    "bike_rig.ros.nodes.parameter": {"measurements": "input"},
    "bike_rig.ros.nodes.recorder": {"output": "output"},
}

#: Parameters that stand for one another, per node module: an override of one of them in
#: :meth:`Graph.with_parameters` (e.g. ``--param driver.session=DIR/session.yaml``) sets the
#: others to "" (wherever they were set: the graph file, the parameter file), unless it sets
#: them too (the sim source takes a session or a bicycle, not both).
ALTERNATIVES: Mapping[str, tuple[frozenset[str], ...]] = {
    "bike_rig.ros.nodes.driver": (frozenset({"session", "bicycle"}),),
}


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
        """A copy with extra ``-p`` overrides per node name (see :data:`ALTERNATIVES`).

        Raises:
            LaunchError: An override names a node the graph does not have.
        """
        known = {n.name for n in self.nodes}
        for name in overrides:
            if name not in known:
                raise LaunchError(f"{self.path}: no node named '{name}' (nodes: {', '.join(sorted(known))})")
        nodes = tuple(
            NodeSpec(n.name, n.module, n.params_file, _merged(n, overrides.get(n.name, {}))) for n in self.nodes
        )
        return Graph(nodes, self.path)

    def subset(self, only: Sequence[str] = (), without: Sequence[str] = ()) -> Graph:
        """A copy with only the nodes named in ``only`` (all if empty), less those in ``without``.

        For a graph split over two hosts (``bike-rig run --only driver`` beside the rig,
        ``--without driver`` at the desk); the start order is kept.

        Raises:
            LaunchError: A name the graph does not have, or no node left.
        """
        known = [n.name for n in self.nodes]
        for name in (*only, *without):
            if name not in known:
                raise LaunchError(f"{self.path}: no node named '{name}' (nodes: {', '.join(known)})")
        nodes = tuple(n for n in self.nodes if (not only or n.name in only) and n.name not in without)
        if not nodes:
            raise LaunchError(f"{self.path}: no node left to start (--only {only}, --without {without})")
        return Graph(nodes, self.path)

    def checked(self, cwd: Path | None = None) -> Graph:
        """A copy whose overrides are checked and whose file parameters are absolute.

        See the module docstring. Nodes whose module declares no parameter specs (someone
        else's node, a test double) are passed on unchecked.

        Args:
            cwd: The directory relative paths start from (default: the current directory).

        Returns:
            The graph to start: every override converted to its parameter's type, every file
            parameter (:data:`PATH_PARAMETERS`) absolute.

        Raises:
            LaunchError: An unknown parameter name, a bad value, a file that does not exist
                or an output that does (one line naming the node and the parameter).
            InputFileError: A node's parameter file cannot be read.
        """
        base = Path.cwd() if cwd is None else cwd
        return Graph(tuple(_checked_node(n, base) for n in self.nodes), self.path)

    def node(self, name: str) -> NodeSpec:
        """The node called ``name``.

        Raises:
            LaunchError: No such node.
        """
        for n in self.nodes:
            if n.name == name:
                return n
        raise LaunchError(f"{self.path}: no node named '{name}' (nodes: {', '.join(n.name for n in self.nodes)})")


def _merged(node: NodeSpec, overrides: Mapping[str, object]) -> dict[str, object]:
    """The node's overrides with ``overrides`` on top; an override of one of :data:`ALTERNATIVES` clears the others."""
    merged = {**node.parameters, **overrides}
    for group in ALTERNATIVES.get(node.module, ()):
        if group & overrides.keys():
            merged.update({other: "" for other in sorted(group - overrides.keys())})
    return merged


def _params_file_values(path: Path, ros_name: str) -> tuple[dict[str, object], set[str]]:
    """The values a ``--params-file`` gives node ``ros_name``, and the names set for it by name.

    Sections ``/**`` (every node) and ``<name>`` or ``/<name>`` are read; only the named
    sections' keys are checked against the node's parameters (a ``/**`` section may hold
    other nodes' parameters).

    Raises:
        InputFileError: The file cannot be read or is not YAML.
    """
    data, _ = load_yaml_document(path)
    values: dict[str, object] = {}
    named: set[str] = set()
    if not isinstance(data, dict):
        return values, named
    for key in ("/**", ros_name, f"/{ros_name}"):
        section = data.get(key)
        params = section.get("ros__parameters") if isinstance(section, dict) else None
        if isinstance(params, dict):
            values.update({str(k): v for k, v in params.items()})
            if key != "/**":
                named.update(str(k) for k in params)
    return values, named


def _unknown_parameter(node: NodeSpec, name: str, specs: Sequence[ParamSpec], where: str) -> LaunchError:
    names = [s.name for s in specs]
    close = difflib.get_close_matches(name, names, n=1)
    hint = f" (did you mean '{close[0]}'?)" if close else ""
    return LaunchError(f"{where}node '{node.name}' has no parameter '{name}'{hint}; its parameters: {', '.join(names)}")


def _as_text(value: object) -> str:
    """A YAML scalar given for a string parameter, as the text typed (``0`` → ``"0"``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    return "" if value is None else str(value)


def _checked_value(node: NodeSpec, spec: ParamSpec, value: object) -> object:
    if spec.kind == "string" and not isinstance(value, str):
        value = _as_text(value)
    try:
        return spec.validate(value)
    except ParamValueError as exc:
        raise LaunchError(f"node '{node.name}': {parameter_message(spec.name, exc.reason, value)}") from None


def _resolve_path(node: NodeSpec, name: str, value: str, kind: str, cwd: Path, folders: Sequence[Path]) -> str:
    """The absolute path of a file parameter (see the module docstring).

    Args:
        node: The node.
        name: The parameter.
        value: Its value (not empty).
        kind: ``input`` or ``output``.
        cwd: The current directory.
        folders: Where else a relative input is looked for, in order, after ``cwd``.

    Raises:
        LaunchError: An output that exists.
    """
    path = Path(value).expanduser()
    if kind == "output":
        out = path if path.is_absolute() else cwd / path
        if out.exists():
            reason = f"{out} exists already (a bag is never overwritten)"
            raise LaunchError(f"node '{node.name}': {parameter_message(name, reason, value)}")
        return os.path.abspath(out)
    candidates = [path] if path.is_absolute() else [cwd / path, *(f / path for f in folders)]
    found = next((c for c in candidates if c.exists()), None)
    return os.path.abspath(found if found is not None else candidates[0])


def _checked_overrides(node: NodeSpec, specs: Sequence[ParamSpec], named: set[str]) -> dict[str, object]:
    """The node's overrides checked against its specs (and the names its parameter file sets)."""
    from .nodes.settings import ROS_BUILTIN_PARAMETERS

    by_name = {s.name: s for s in specs}
    known = by_name.keys() | ROS_BUILTIN_PARAMETERS
    for name in sorted(named - known):
        raise _unknown_parameter(node, name, specs, f"{node.params_file}: ")
    params = dict(node.parameters)
    for name, value in node.parameters.items():
        if name not in known:
            raise _unknown_parameter(node, name, specs, "")
        if name in by_name:
            params[name] = _checked_value(node, by_name[name], value)
    return params


def _resolve_paths(node: NodeSpec, params: dict[str, object], file_values: Mapping[str, object], cwd: Path) -> None:
    """Make the node's file parameters (:data:`PATH_PARAMETERS`) absolute overrides, in place."""
    file_folder = [node.params_file.parent] if node.params_file is not None else []
    for name, kind in PATH_PARAMETERS.get(node.module, {}).items():
        given = name in params
        value = params[name] if given else file_values.get(name)
        if not isinstance(value, str) or not value.strip():
            continue
        folders = [config_dir()] if given else [*file_folder, config_dir()]
        resolved = _resolve_path(node, name, value, kind, cwd, folders)
        if given and kind == "input" and not Path(resolved).exists():
            looked = ", ".join(str(f) for f in (cwd, *folders))
            reason = f"no such file (looked in {looked})"
            raise LaunchError(f"node '{node.name}': {parameter_message(name, reason, value)}")
        params[name] = resolved


def _checked_node(node: NodeSpec, cwd: Path) -> NodeSpec:
    """One node of :meth:`Graph.checked`."""
    from .nodes.settings import node_parameter_specs, node_ros_name

    specs = node_parameter_specs(node.module)
    file_values: dict[str, object] = {}
    named: set[str] = set()
    if node.params_file is not None:
        file_values, named = _params_file_values(node.params_file, node_ros_name(node.module))
    params = dict(node.parameters) if specs is None else _checked_overrides(node, specs, named)
    _resolve_paths(node, params, file_values, cwd)
    return NodeSpec(node.name, node.module, node.params_file, params)


def _params_path(path: str, base: Path, value: object, key: str, line: int | None) -> Path:
    """A node's ``params:`` file, relative to the graph file's folder ``base``.

    Raises:
        InputFileError: not a string naming an existing file (the name too long included).
    """
    if not isinstance(value, str) or not value:
        raise InputFileError(path, f"expected a file name, got {short_repr(value)}", key=key, line=line)
    try:
        found = (base / value).resolve()
        exists = found.is_file()
    except (OSError, ValueError) as exc:  # a name too long for the file system, a NUL byte
        reason = f"cannot use {short_repr(value)} as a file ({getattr(exc, 'strerror', None) or one_line(str(exc))})"
        raise InputFileError(path, reason, key=key, line=line) from None
    if not exists:
        raise InputFileError(path, f"parameter file {found} not found", key=key, line=line)
    return found


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
            params_file = _params_path(p, base, e["params"], f"{where}.params", line)
        parameters = e.get("parameters") or {}
        if not isinstance(parameters, dict):
            raise InputFileError(p, "'parameters' must be a mapping", key=f"{where}.parameters", line=line)
        nodes.append(NodeSpec(e["name"], e["module"], params_file, parameters))
    names = [n.name for n in nodes]
    if len(set(names)) != len(names):
        raise InputFileError(p, "node names must be unique", key="nodes", line=lines.get(("nodes",)))
    return Graph(tuple(nodes), p)


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
