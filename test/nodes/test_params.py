"""Declaring node parameters from specs (bike_rig.ros.nodes.settings), in this process.

Descriptors, values from overrides, and every kind of bad value as one NodeParameterError line.
"""

from __future__ import annotations

import contextlib
import uuid
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import rclpy
from rclpy.context import Context
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions

from bike_rig.config.settings import ParamSpec
from bike_rig.sources import backend_parameters
from bike_rig.sources.base import TIME_SCALE

pytestmark = pytest.mark.ros

NodeFactory = Callable[..., Any]


@pytest.fixture
def make_node(ros_env: dict[str, str], ros_domain_id: int, monkeypatch: pytest.MonkeyPatch) -> Iterator[NodeFactory]:
    """Build rclpy nodes (in a context of their own) with the given parameter overrides."""
    for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID", "RMW_IMPLEMENTATION"):
        monkeypatch.setenv(key, ros_env[key])
    monkeypatch.delenv("ROS_LOCALHOST_ONLY", raising=False)
    context = Context()
    rclpy.init(context=context, domain_id=ros_domain_id, signal_handler_options=SignalHandlerOptions.NO)
    nodes: list[Any] = []

    def make(**overrides: Any) -> Any:
        params = [Parameter(name, value=value) for name, value in overrides.items()]
        node = rclpy.create_node(f"params_{uuid.uuid4().hex[:8]}", context=context, parameter_overrides=params)
        nodes.append(node)
        return node

    try:
        yield make
    finally:
        for node in nodes:
            with contextlib.suppress(Exception):
                node.destroy_node()
        rclpy.shutdown(context=context)


SPECS = (
    ParamSpec("mode", "a", "a mode", choices=("a", "b")),
    ParamSpec("count", 4, "a count", (1, 64)),
    TIME_SCALE,
    ParamSpec("flush_period", 0.5, "s", (0.0, 1.0), open_low=True, loose_type=True),
    ParamSpec("topics", ("all",), "names", loose_type=True),
    ParamSpec("flag", False, "a flag"),
)


def test_descriptors_carry_ranges_and_choices() -> None:
    from bike_rig.ros.nodes.settings import descriptor

    mode, count, scale, flush, topics, _ = (descriptor(s) for s in SPECS)
    assert mode.read_only and mode.additional_constraints == "one of: a, b" and mode.description == "a mode"
    assert (count.integer_range[0].from_value, count.integer_range[0].to_value) == (1, 64)
    assert (scale.floating_point_range[0].from_value, scale.floating_point_range[0].to_value) == (0.001, 1000.0)
    assert flush.dynamic_typing and flush.additional_constraints == "within (0, 1]"
    assert topics.dynamic_typing and not mode.dynamic_typing


def test_defaults_and_overrides_are_read_and_converted(make_node: NodeFactory) -> None:
    from bike_rig.ros.nodes.settings import declare_parameters

    assert declare_parameters(make_node(), SPECS) == {
        "mode": "a",
        "count": 4,
        "time_scale": 1.0,
        "flush_period": 0.5,
        "topics": ("all",),
        "flag": False,
    }
    node = make_node(mode="b", count=64, time_scale=20.0, flush_period=1, topics="gyro", flag=True)
    values = declare_parameters(node, SPECS)
    assert values == {
        "mode": "b",
        "count": 64,
        "time_scale": 20.0,
        "flush_period": 1.0,
        "topics": ("gyro",),
        "flag": True,
    }
    assert isinstance(values["flush_period"], float)
    assert node.get_parameter("time_scale").value == 20.0
    assert node.describe_parameter("count").read_only


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"time_scale": 20}, "parameter 'time_scale': expected a double (e.g. 20.0)"),
        ({"time_scale": 5000.0}, "parameter 'time_scale': must be within [0.001, 1000]"),
        ({"count": 0}, "parameter 'count': must be within [1, 64]"),
        ({"count": 2.0}, "parameter 'count': expected an integer"),
        ({"mode": "c"}, "parameter 'mode' = 'c': expected one of a, b"),
        ({"flush_period": 0.0}, "parameter 'flush_period': must be within (0, 1]"),
        ({"flush_period": 2}, "parameter 'flush_period': must be within (0, 1]"),
        ({"flush_period": 2.0}, "parameter 'flush_period': must be within (0, 1]"),
        ({"flush_period": "x"}, "parameter 'flush_period': expected a double (e.g. 0.5)"),
        ({"topics": 3}, "parameter 'topics': expected a list of strings"),
        ({"flag": "yes"}, "parameter 'flag': expected true or false"),
    ],
)
def test_bad_values_are_one_error(make_node: NodeFactory, overrides: dict[str, Any], message: str) -> None:
    from bike_rig.ros.nodes.settings import NodeParameterError, declare_parameters

    with pytest.raises(NodeParameterError) as info:
        declare_parameters(make_node(**overrides), SPECS)
    assert str(info.value) == message


def test_the_driver_declares_every_backends_parameters() -> None:
    from bike_rig.ros.nodes.driver import COMMON_PARAMETERS, driver_parameters

    specs = driver_parameters()
    assert specs[: len(COMMON_PARAMETERS)] == COMMON_PARAMETERS
    assert set(backend_parameters()) <= set(specs)
    assert len({s.name for s in specs}) == len(specs)
