"""The package's shape: the ROS boundary is one package, dependencies point one way, modules stay small.

Everything that imports rclpy, a ROS message package or the Foxglove SDK lives under
``bike_rig/ros/``; nothing else imports those or :mod:`bike_rig.ros` when it is imported (the
CLI alone reaches into ``ros/``, from inside the function that needs it). The ROS-free layers
(``config/``, ``core/``, ``pipeline/``, ``messages/``) import nothing above them. Checked on the
source text with :mod:`ast`, and by importing every module outside ``ros/`` with ROS blocked.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "bike_rig"
#: Third-party packages only ``bike_rig/ros/`` may import: the ROS runtime, its messages, the Foxglove SDK.
ROS_ONLY = (
    "rclpy",
    "rcl_interfaces",
    "bike_rig_msgs",
    "std_msgs",
    "builtin_interfaces",
    "diagnostic_msgs",
    "sensor_msgs",
    "foxglove",
)
#: The package of the ROS boundary.
ROS = "bike_rig.ros"
#: Packages outside ``ros/`` allowed to import it, from inside a function only.
ROS_CALLERS = {"cli"}
#: Longest module, lines.
MAX_LINES = 650
#: Each ROS-free layer, and the packages above it that it must not import.
ABOVE = {
    "config": (
        "bike_rig.core",
        "bike_rig.pipeline",
        "bike_rig.messages",
        "bike_rig.bag",
        "bike_rig.offline",
        "bike_rig.sources",
        "bike_rig.session",
        "bike_rig.console",
        "bike_rig.plots",
        "bike_rig.report",
        "bike_rig.cli",
        ROS,
    ),
    "core": (
        "bike_rig.pipeline",
        "bike_rig.messages",
        "bike_rig.bag",
        "bike_rig.offline",
        "bike_rig.sources",
        "bike_rig.plots",
        "bike_rig.report",
        "bike_rig.cli",
        ROS,
    ),
    "pipeline": (
        "bike_rig.messages",
        "bike_rig.bag",
        "bike_rig.offline",
        "bike_rig.sources",
        "bike_rig.plots",
        "bike_rig.report",
        "bike_rig.cli",
        ROS,
    ),
    "messages": (
        "bike_rig.bag",
        "bike_rig.offline",
        "bike_rig.sources",
        "bike_rig.plots",
        "bike_rig.report",
        "bike_rig.cli",
        ROS,
    ),
}


def _module(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _names(node: ast.Import | ast.ImportFrom, package: list[str]) -> set[str]:
    if isinstance(node, ast.Import):
        return {a.name for a in node.names}
    base = package[: len(package) - node.level + 1] if node.level else []
    module = ".".join([*base, *([node.module] if node.module else [])])
    return {module} | {f"{module}.{a.name}" for a in node.names}


def _imports(path: Path) -> Iterator[tuple[ast.Import | ast.ImportFrom, bool]]:
    """Every import statement of ``path``, and whether it runs when the module is imported.

    Imports inside a function or an ``if TYPE_CHECKING:`` block do not run then.
    """

    def walk(node: ast.AST, at_import: bool) -> Iterator[tuple[ast.Import | ast.ImportFrom, bool]]:
        for child in ast.iter_child_nodes(node):
            now = at_import and not isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda)
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                now = False
            if isinstance(child, ast.Import | ast.ImportFrom):
                yield child, now
            yield from walk(child, now)

    yield from walk(ast.parse(path.read_text(), str(path)), True)


def _package(path: Path) -> list[str]:
    package = _module(path).split(".")
    return package if path.name == "__init__.py" else package[:-1]


def imported_modules(path: Path, at_import_only: bool = False) -> set[str]:
    """Every module ``path`` imports (relative imports resolved): anywhere, or only when it is imported."""
    out: set[str] = set()
    for node, at_import in _imports(path):
        if at_import or not at_import_only:
            out |= _names(node, _package(path))
    return out


def sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def _under(path: Path, *folders: str) -> bool:
    return path.relative_to(PACKAGE).parts[0] in folders


def _ros_bound(module: str) -> bool:
    return module.split(".")[0] in ROS_ONLY or module == ROS or module.startswith(ROS + ".")


def test_imported_modules_resolves_relative_imports() -> None:
    got = imported_modules(PACKAGE / "offline" / "replay.py")
    assert "bike_rig.pipeline.offline" in got and "bike_rig.messages" in got


def test_imported_modules_tells_lazy_imports_apart() -> None:
    everywhere = imported_modules(PACKAGE / "cli" / "run_cmd.py")
    at_import = imported_modules(PACKAGE / "cli" / "run_cmd.py", at_import_only=True)
    assert "bike_rig.ros.launch" in everywhere and "bike_rig.ros.launch" not in at_import


def test_no_module_outside_ros_imports_ros_when_imported() -> None:
    offenders = []
    for path in sources():
        if _under(path, "ros"):
            continue
        lazy = _under(path, *ROS_CALLERS)
        bad = sorted(m for m in imported_modules(path, at_import_only=lazy) if _ros_bound(m))
        if bad:
            offenders.append(f"{path.relative_to(PACKAGE)}: {', '.join(bad)}")
    assert offenders == []


def test_every_module_outside_ros_imports_with_ros_absent() -> None:
    """Import each module outside ``ros/`` in a fresh interpreter where ROS and Foxglove cannot be imported."""
    modules = [_module(p) for p in sources() if not _under(p, "ros")]
    script = (
        "import importlib, sys\n"
        f"for name in {list(ROS_ONLY)!r}:\n"
        "    sys.modules[name] = None\n"
        f"for module in {modules!r}:\n"
        "    importlib.import_module(module)\n"
        "print(len(sys.modules))\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]


def test_the_ros_package_holds_every_rclpy_user() -> None:
    users = {p.relative_to(PACKAGE).parts[0] for p in sources() if any(_ros_bound(m) for m in imported_modules(p))}
    assert "ros" in users and users <= {"ros", *ROS_CALLERS}


@pytest.mark.parametrize("layer", sorted(ABOVE))
def test_ros_free_layers_import_no_ros_and_nothing_above_them(layer: str) -> None:
    above = ABOVE[layer]
    offenders = []
    for path in (PACKAGE / layer).rglob("*.py"):
        for m in imported_modules(path):
            if _ros_bound(m) or any(m == a or m.startswith(a + ".") for a in above):
                offenders.append(f"{path.relative_to(PACKAGE)}: {m}")
    assert offenders == []


def test_no_module_is_too_long() -> None:
    long = [f"{p.relative_to(PACKAGE)}: {n}" for p in sources() if (n := len(p.read_text().splitlines())) > MAX_LINES]
    assert long == []
