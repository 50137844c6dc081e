"""Node settings as ROS parameters: a node's :class:`~bike_rig.config.settings.ParamSpec` list, declared read-only.

Every bike_rig node declares its parameters with :func:`declare_parameters`: each spec becomes a
read-only parameter whose descriptor carries the description, the range (``integer_range`` or
``floating_point_range``) and the choices (``additional_constraints``), so ``ros2 param
describe`` documents it; values come from ``--params-file`` and ``-p NAME:=VALUE``. rclpy
enforces the type and the range; the spec's own check (:meth:`~bike_rig.config.settings.ParamSpec.validate`)
then enforces what ROS descriptors cannot express (choices, a range open at its low end, a
finite double). Whatever is wrong ends as one :class:`NodeParameterError` whose message is one
line, which the node runner prints as ``<node>: error: <message>`` before exiting with status 2:

* ``parameter 'time_scale': expected a double (e.g. 20.0)`` (the wrong type);
* ``parameter 'time_scale': must be within [0.001, 1000]`` (out of range);
* ``parameter 'source' = 'nope': expected one of sim, can, bag, daq`` (not a choice).
"""

from __future__ import annotations

import importlib
from collections.abc import Iterable
from typing import Any

from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.node import Node

from ...config.settings import ParamRangeError, ParamSpec, ParamTypeError, ParamValueError, parameter_message
from ...core.errors import BikeRigError

__all__ = [
    "ROS_BUILTIN_PARAMETERS",
    "NodeParameterError",
    "declare_parameter",
    "declare_parameters",
    "descriptor",
    "node_parameter_specs",
    "node_ros_name",
    "parameter_error",
]

# rcl_interfaces ships no type information: imported by name
_rcl: Any = importlib.import_module("rcl_interfaces.msg")


class NodeParameterError(BikeRigError):
    """A node parameter that cannot be used.

    The wrong type, out of range, not one of the choices, or inconsistent with another. The
    message is one line naming the parameter.
    """


def parameter_error(name: str, reason: str, value: object = None) -> NodeParameterError:
    """The error for node parameter ``name``: ``parameter 'name' [= value]: reason``.

    Args:
        name: The parameter.
        reason: Why its value cannot be used.
        value: The value given, or None to leave it out of the message.
    """
    return NodeParameterError(parameter_message(name, reason, value))


def descriptor(spec: ParamSpec) -> Any:
    """The read-only ``rcl_interfaces/ParameterDescriptor`` of a spec.

    Returns:
        The descriptor: description, range (integer or floating point), the choices or the
        constraints in words, and dynamic typing for a ``loose_type`` spec.
    """
    desc = _rcl.ParameterDescriptor(description=spec.description, read_only=True, dynamic_typing=spec.loose_type)
    if spec.constraints:
        desc.additional_constraints = spec.constraints
    elif spec.choices:
        desc.additional_constraints = "one of: " + ", ".join(spec.choices)
    elif spec.open_low:
        desc.additional_constraints = f"within {spec.range_text}"
    if spec.range is not None and spec.kind == "double":
        low, high = (float(x) for x in spec.range)
        desc.floating_point_range = [_rcl.FloatingPointRange(from_value=low, to_value=high, step=0.0)]
    elif spec.range is not None and spec.kind == "integer":
        low_i, high_i = (int(x) for x in spec.range)
        desc.integer_range = [_rcl.IntegerRange(from_value=low_i, to_value=high_i, step=1)]
    return desc


def _given(node: Node, name: str) -> object:
    """The value given for ``name`` (command line or parameter file), or None.

    rclpy keeps these overrides on the node and does not put them in its exceptions; read only
    to quote the value in a message.
    """
    override = getattr(node, "_parameter_overrides", {}).get(name)
    return None if override is None else override.value


def _type_reason(spec: ParamSpec, given: object) -> str:
    """What a value of the wrong type should have been (``expected a double (e.g. 20.0)``)."""
    kind = spec.kind
    if kind == "double":
        whole = isinstance(given, int) and not isinstance(given, bool)
        example = float(given) if whole else float(spec.default)  # type: ignore[arg-type]
        return f"expected a double (e.g. {example!r})"
    return {
        "bool": "expected true or false",
        "integer": "expected an integer",
        "string": "expected a string",
        "string list": "expected a list of strings",
    }[kind]


def declare_parameter(node: Node, spec: ParamSpec) -> Any:
    """Declare one read-only parameter and return its checked value.

    Args:
        node: The node.
        spec: The parameter.

    Returns:
        The value (given, or the default) as the spec's type; a string list as a tuple.

    Raises:
        NodeParameterError: The value has the wrong type, is out of range or not a choice.
    """
    default = list(spec.default) if isinstance(spec.default, tuple) else spec.default
    try:
        value: object = node.declare_parameter(spec.name, default, descriptor(spec)).value
    except InvalidParameterTypeException:
        raise parameter_error(spec.name, _type_reason(spec, _given(node, spec.name))) from None
    except InvalidParameterValueException:
        raise parameter_error(spec.name, f"must be within {spec.range_text}") from None
    try:
        return spec.validate(value)
    except ParamRangeError:
        raise parameter_error(spec.name, f"must be within {spec.range_text}") from None
    except ParamTypeError:
        raise parameter_error(spec.name, _type_reason(spec, value)) from None
    except ParamValueError as exc:
        raise parameter_error(spec.name, exc.reason, value) from None


def declare_parameters(node: Node, specs: Iterable[ParamSpec]) -> dict[str, Any]:
    """Declare every spec as a read-only parameter (in order) and return the checked values.

    Args:
        node: The node.
        specs: Its parameters.

    Returns:
        Name → value, as :func:`declare_parameter` returns them.

    Raises:
        NodeParameterError: The first parameter whose value cannot be used.
    """
    return {spec.name: declare_parameter(node, spec) for spec in specs}


#: Parameters that rclpy declares on every node itself (not in a node's spec list).
ROS_BUILTIN_PARAMETERS: frozenset[str] = frozenset({"use_sim_time", "start_type_description_service"})


def node_parameter_specs(module: str) -> tuple[ParamSpec, ...] | None:
    """The parameters a node module declares, without starting it.

    A bike_rig node module publishes its spec list as ``PARAMETERS`` (a tuple of specs) or as a
    function ``<last part of the module name>_parameters()`` (``driver_parameters``,
    ``fitter_parameters``). The launcher checks ``--param`` names and values against it
    before anything starts.

    Args:
        module: The node's module, e.g. ``bike_rig.ros.nodes.driver``.

    Returns:
        The specs, or None for a module outside ``bike_rig`` (not imported here: a node of
        someone else's, a test double) or one that publishes none: then nothing is checked.
    """
    if not module.startswith("bike_rig."):
        return None
    try:
        mod = importlib.import_module(module)
    except ImportError:
        return None
    specs = getattr(mod, "PARAMETERS", None)
    if specs is None:
        factory = getattr(mod, f"{module.rpartition('.')[2]}_parameters", None)
        specs = factory() if callable(factory) else None
    if not isinstance(specs, tuple) or not all(isinstance(s, ParamSpec) for s in specs):
        return None
    return specs


def node_ros_name(module: str) -> str:
    """The ROS name of the node a bike_rig module runs: its ``NODE_NAME``, else the module's last part."""
    if not module.startswith("bike_rig."):
        return module.rpartition(".")[2]
    try:
        mod = importlib.import_module(module)
    except ImportError:
        return module.rpartition(".")[2]
    name = getattr(mod, "NODE_NAME", None)
    return name if isinstance(name, str) and name else module.rpartition(".")[2]
