"""Reference pages generated from the code: topics and services, node parameters."""

from __future__ import annotations

import ast
from pathlib import Path

from bike_rig.config import topics
from bike_rig.ros.nodes.settings import node_parameter_specs

#: The node modules whose parameters the manual lists, in data-flow order.
NODE_MODULES = (
    "bike_rig.ros.nodes.driver",
    "bike_rig.ros.nodes.fitter",
    "bike_rig.ros.nodes.parameter",
    "bike_rig.ros.nodes.model",
    "bike_rig.ros.nodes.recorder",
    "bike_rig.ros.nodes.foxglove_bridge",
)


def _number(x: float) -> str:
    return f"{int(x):,}" if float(x).is_integer() else f"{x:g}"


def _cell(text: object) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def topics_page() -> str:
    """The topics (name, type, QoS) and services of ``bike_rig.config.topics``."""
    lines = ["# Topics and services", "", "Generated from `bike_rig/config/topics.py`.", ""]
    lines += ["| topic | type | reliability | durability | depth |", "| --- | --- | --- | --- | --- |"]
    for value in vars(topics).values():
        if isinstance(value, topics.Topic):
            q = value.qos
            reliability = "reliable" if q.reliable else "best effort"
            durability = "transient local" if q.transient_local else "volatile"
            lines.append(f"| `{value.name}` | `{value.type}` | {reliability} | {durability} | {q.depth} |")
    lines += ["", "| service | name |", "| --- | --- |"]
    for key, value in vars(topics).items():
        if key.isupper() and isinstance(value, str) and value.startswith(topics.NAMESPACE + "/") and key != "NAMESPACE":
            lines.append(f"| `{key}` | `{value}` |")
    return "\n".join(lines) + "\n"


def parameters_page() -> str:
    """Every node's parameters from its ``ParamSpec`` list."""
    lines = ["# Node parameters", "", "Generated from each node's `ParamSpec` list.", ""]
    for module in NODE_MODULES:
        specs = node_parameter_specs(module)
        if not specs:
            continue
        lines += [f"## `{module.rpartition('.')[2]}`", "", "| name | default | range or choices | description |"]
        lines.append("| --- | --- | --- | --- |")
        for s in specs:
            bounds = f"{_number(s.range[0])} … {_number(s.range[1])}" if s.range else ""
            accepted = ", ".join(s.choices) if s.choices else bounds
            lines.append(f"| `{s.name}` | `{_cell(s.default)}` | {_cell(accepted)} | {_cell(s.description)} |")
        lines.append("")
    return "\n".join(lines)


def benchmarks_page(bench: Path) -> str:
    """The benchmark scripts of ``make bench``, each with its docstring's first line."""
    lines = ["# Benchmarks", "", "`make bench` runs every script below and prints its measurements; numbers live"]
    lines += ["in that output, not in this manual.", "", "| script | what it measures |", "| --- | --- |"]
    for script in sorted(bench.glob("bench_*.py")):
        doc = ast.get_docstring(ast.parse(script.read_text(encoding="utf-8"))) or ""
        lines.append(f"| `bench/{script.name}` | {_cell(doc.splitlines()[0] if doc else '')} |")
    return "\n".join(lines) + "\n"


def write_reference(folder: Path) -> None:
    """Write the generated pages into ``folder`` (only when their text changed)."""
    folder.mkdir(exist_ok=True)
    pages = {
        "topics.md": topics_page(),
        "node-parameters.md": parameters_page(),
        "benchmarks.md": benchmarks_page(folder.parent.parent / "bench"),
    }
    for name, text in pages.items():
        path = folder / name
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")
