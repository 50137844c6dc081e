"""Fixtures of the node tests: the nodes' environment and the parameter/model probe.

A test module that needs another probe (the driver's, :class:`test.nodes.test_driver.Probe`)
defines its own ``probe`` fixture, which takes precedence.
"""

from __future__ import annotations

import pytest

from test.support.nodes import node_environment


@pytest.fixture
def node_env(ros_env: dict[str, str]) -> dict[str, str]:
    """The nodes' environment: the run's ROS environment, this checkout first on the path."""
    return node_environment(ros_env)
