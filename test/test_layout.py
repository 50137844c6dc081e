"""The package's shape: dependencies point one way, and modules stay small.

Nothing outside ``bike_rig/ros/nodes/`` imports :mod:`bike_rig.ros.nodes` (the launcher and the CLI
aside: they start node processes); the ROS-free layers (``core/``, ``pipeline/``,
``messages/``) import no ROS runtime and nothing above them. Checked on the source text with
:mod:`ast`, so a lazy import inside a function counts too.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "bike_rig"
#: Modules allowed to import bike_rig.ros.nodes besides the nodes themselves.
NODE_IMPORTERS = {"cli"}
#: ROS runtime packages the ROS-free layers must not import.
ROS_RUNTIME = ("rclpy", "rcl_interfaces", "bike_rig_msgs", "std_msgs", "builtin_interfaces")
#: Longest module, lines.
MAX_LINES = 650


def _module(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_modules(path: Path) -> set[str]:
    """Every module ``path`` imports (relative imports resolved), anywhere in the file."""
    tree = ast.parse(path.read_text(), str(path))
    package = _module(path).split(".")
    if path.name != "__init__.py":
        package = package[:-1]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package[: len(package) - node.level + 1] if node.level else []
            module = ".".join([*base, *([node.module] if node.module else [])])
            out.add(module)
            out.update(f"{module}.{a.name}" for a in node.names)
    return out


def sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def _under(path: Path, *folders: str) -> bool:
    return path.relative_to(PACKAGE).parts[0] in folders


def test_imported_modules_resolves_relative_imports() -> None:
    got = imported_modules(PACKAGE / "offline" / "replay.py")
    assert "bike_rig.pipeline.offline" in got and "bike_rig.messages" in got


def test_nothing_outside_nodes_imports_nodes() -> None:
    offenders = []
    for path in sources():
        if _under(path, "ros", *NODE_IMPORTERS):
            continue
        bad = sorted(
            m for m in imported_modules(path) if m == "bike_rig.ros.nodes" or m.startswith("bike_rig.ros.nodes.")
        )
        if bad:
            offenders.append(f"{path.relative_to(PACKAGE)}: {', '.join(bad)}")
    assert offenders == []


@pytest.mark.parametrize("layer", ["core", "pipeline", "messages"])
def test_ros_free_layers_import_no_ros_and_nothing_above_them(layer: str) -> None:
    above = {
        "core": (
            "bike_rig.pipeline",
            "bike_rig.messages",
            "bike_rig.ros.nodes",
            "bike_rig.bag",
            "bike_rig.cli",
            "bike_rig.plots",
            "bike_rig.report",
            "bike_rig.sources",
            "bike_rig.offline.subjects",
        ),
        "pipeline": (
            "bike_rig.messages",
            "bike_rig.ros.nodes",
            "bike_rig.bag",
            "bike_rig.cli",
            "bike_rig.plots",
            "bike_rig.report",
            "bike_rig.sources",
            "bike_rig.offline.subjects",
        ),
        "messages": (
            "bike_rig.ros.nodes",
            "bike_rig.bag",
            "bike_rig.cli",
            "bike_rig.plots",
            "bike_rig.report",
            "bike_rig.sources",
            "bike_rig.offline.subjects",
        ),
    }[layer]
    offenders = []
    for path in (PACKAGE / layer).rglob("*.py"):
        for m in imported_modules(path):
            if m.split(".")[0] in ROS_RUNTIME or any(m == a or m.startswith(a + ".") for a in above):
                offenders.append(f"{path.relative_to(PACKAGE)}: {m}")
    assert offenders == []


def test_no_module_is_too_long() -> None:
    long = [f"{p.relative_to(PACKAGE)}: {n}" for p in sources() if (n := len(p.read_text().splitlines())) > MAX_LINES]
    assert long == []
