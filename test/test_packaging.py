"""The package declares what its code imports: PyPI libraries in setup.py, ROS packages in package.xml."""

from __future__ import annotations

import ast
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Import name -> distribution name, where they differ.
DISTRIBUTIONS = {"yaml": "PyYAML", "can": "python-can", "foxglove": "foxglove-sdk"}
#: Imported only when present (vendor drivers of optional hardware).
OPTIONAL = {"nidaqmx"}
#: The project's own packages.
OWN = {"bike_rig", "bike_rig_msgs"}


def _imported() -> set[str]:
    """Top-level names bike_rig imports (statements and importlib.import_module of a literal)."""
    names: set[str] = set()
    for path in (ROOT / "bike_rig").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names.add(node.module.split(".")[0])
            elif (
                isinstance(node, ast.Call)
                and getattr(node.func, "attr", "") == "import_module"
                and node.args
                and isinstance(node.args[0], ast.Constant)
                and isinstance(node.args[0].value, str)
            ):
                names.add(node.args[0].value.split(".")[0])
    return {n for n in names if n not in sys.stdlib_module_names and n not in OWN | OPTIONAL}


def _install_requires() -> set[str]:
    text = (ROOT / "setup.py").read_text(encoding="utf-8")
    block = text[text.index("install_requires=[") : text.index("]", text.index("install_requires=["))]
    return {re.split(r"[<>=!~ ]", r)[0].lower() for r in re.findall(r'"([^"]+)"', block)}


def _package_xml() -> set[str]:
    root = ET.parse(ROOT / "package.xml").getroot()
    return {e.text or "" for e in root if e.tag in ("depend", "exec_depend")}


def test_setup_pins_nothing() -> None:
    text = (ROOT / "setup.py").read_text(encoding="utf-8")
    block = text[text.index("install_requires=[") : text.index("]", text.index("install_requires=["))]
    assert "==" not in block  # pins live in tools/requirements.txt


def test_every_import_is_declared() -> None:
    pypi, ros = _install_requires(), _package_xml()
    missing = [
        name
        for name in sorted(_imported())
        if DISTRIBUTIONS.get(name, name).lower() not in pypi
        and name not in ros
        and f"python3-{DISTRIBUTIONS.get(name, name).lower().removeprefix('py')}" not in ros
    ]
    assert not missing, f"imported by bike_rig but declared in neither setup.py nor package.xml: {missing}"


def test_package_xml_lists_the_ros_runtime() -> None:
    ros = _package_xml()
    for key in (
        "rclpy",
        "std_msgs",
        "sensor_msgs",
        "diagnostic_msgs",
        "python3-numpy",
        "python3-scipy",
        "python3-yaml",
        "python3-matplotlib",
        "python3-can",
    ):
        assert key in ros, key
