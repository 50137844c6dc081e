"""Packaging of the ament_python package bike_rig (configuration of tools: pyproject.toml)."""

from __future__ import annotations

from glob import glob
from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = "bike_rig"
HERE = Path(__file__).resolve().parent


def _files(pattern: str) -> list[str]:
    """Files (not directories) matching a glob relative to this file, sorted."""
    return sorted(p for p in glob(pattern, root_dir=HERE) if (HERE / p).is_file())


setup(
    name=PACKAGE,
    version="0.1.0",
    description="Bicycle parameter measurement rig and Whipple model on ROS 2",
    license="Apache-2.0",
    python_requires=">=3.11",
    packages=find_packages(include=[PACKAGE, f"{PACKAGE}.*"], exclude=["test", "test.*"]),
    package_data={PACKAGE: ["py.typed"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", _files("config/*.yaml")),
        (f"share/{PACKAGE}/config/bicycles", _files("config/bicycles/*")),
        (f"share/{PACKAGE}/config/foxglove", _files("config/foxglove/*")),
        (f"share/{PACKAGE}/config/dds", _files("config/dds/*")),
        (f"share/{PACKAGE}/config/feedback", _files("config/feedback/*")),
    ],
    # The runtime libraries from PyPI, as ranges (the tested pins: tools/requirements.txt). The
    # ROS packages (rclpy, the message packages) are package.xml's, from the ROS prefix.
    install_requires=[
        "numpy>=1.26",
        "scipy>=1.11",
        "PyYAML>=6.0",
        "rosbags>=0.10,<0.12",
        "mcap>=1.2,<2",
        "python-can>=4.3,<5",
        "yeadon>=1.5",
        "matplotlib>=3.8",
        "textual>=1.0",
        "rich>=13",
        "foxglove-sdk>=0.30,<1",
        "websockets>=13",
    ],
    zip_safe=False,
    entry_points={
        "console_scripts": [
            "bike-rig = bike_rig.cli.main:main",
            "bike-rig-driver = bike_rig.ros.nodes.driver:main",
            "bike-rig-fitter = bike_rig.ros.nodes.fitter:main",
            "bike-rig-parameter = bike_rig.ros.nodes.parameter:main",
            "bike-rig-model = bike_rig.ros.nodes.model:main",
            "bike-rig-recorder = bike_rig.ros.nodes.recorder:main",
            "bike-rig-foxglove-bridge = bike_rig.ros.nodes.foxglove_bridge:main",
        ],
    },
)
