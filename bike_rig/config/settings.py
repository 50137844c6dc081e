"""Settings: one spec type for every node setting (a ROS parameter) and every gyro-source option.

A :class:`ParamSpec` names a parameter and gives its default (whose Python type is the
parameter's type), a description, and what values it accepts: an inclusive ``range`` (the low
end excluded with ``open_low``) for numbers, ``choices`` for strings. The same spec is read two
ways:

* by a node, through :mod:`bike_rig.ros.nodes.settings` (ROS parameters with descriptors, read-only);
* by a gyro source, through :class:`bike_rig.sources.base.Parameters` (a plain mapping), so that
  ``open_source("sim", time_scale=20.0)`` checks exactly what the driver node checks.

Both call :meth:`ParamSpec.validate`, which converts a value and raises a
:class:`ParamValueError` naming the reason; the callers turn it into their own one-line error
(:func:`parameter_message` gives the shared wording). Nothing here imports rclpy.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TypeAlias

__all__ = [
    "ParamRangeError",
    "ParamSpec",
    "ParamTypeError",
    "ParamValue",
    "ParamValueError",
    "merge_specs",
    "parameter_message",
]

#: The value types a parameter can have: string, flag, integer, double, list of strings.
ParamValue: TypeAlias = str | bool | int | float | tuple[str, ...]


class ParamValueError(ValueError):
    """A value a spec does not accept; ``reason`` says why (e.g. ``expected one of a, b``).

    Args:
        reason: Why the value cannot be used, without the parameter's name.
    """

    def __init__(self, reason: str):
        """Keep ``reason`` (also the message)."""
        super().__init__(reason)
        self.reason = reason


class ParamTypeError(ParamValueError):
    """The value has the wrong type."""


class ParamRangeError(ParamValueError):
    """The number is outside the spec's range."""


def parameter_message(name: str, reason: str, value: object = None) -> str:
    """The one-line wording of a bad parameter: ``parameter 'name' = value: reason``.

    Args:
        name: The parameter.
        reason: Why its value cannot be used.
        value: The value given (shown with ``repr``), or None to leave it out.

    Returns:
        The message, e.g. ``parameter 'source' = 'nope': expected one of sim, can, bag, daq``.
    """
    shown = "" if value is None else f" = {value!r}"
    return f"parameter '{name}'{shown}: {reason}"


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: its name, default (and so its type), description and accepted values.

    Attributes:
        name: The parameter's name (a ROS parameter name, e.g. ``time_scale``).
        default: The default value; its type is the parameter's: ``str``, ``bool``, ``int``,
            ``float`` or ``tuple[str, ...]`` (a string list).
        description: One line for ``ros2 param describe``, with the unit (e.g. ``..., s``).
        range: Inclusive ``(low, high)`` bounds of a number, in its unit; None for any.
        choices: The accepted strings; empty for any.
        open_low: The range excludes its low end: ``(low, high]``.
        loose_type: A node also accepts an integer for a double and one string for a string
            list (parameters typed by hand, e.g. the recorder's); else the type must match.
        constraints: Further constraints in words, for the descriptor (checked by the node).

    Raises:
        ValueError: An inconsistent spec (a programming error): a range on a non-number,
            choices on a non-string, or a default the spec itself refuses.
    """

    name: str
    default: ParamValue
    description: str
    range: tuple[float, float] | None = None
    choices: tuple[str, ...] = field(default=())
    open_low: bool = False
    loose_type: bool = False
    constraints: str = ""

    def __post_init__(self) -> None:
        """Check the spec itself (see Raises above)."""
        numeric = self.kind in ("integer", "double")
        if self.range is not None and not numeric:
            raise ValueError(f"parameter spec {self.name!r}: a range needs a numeric default")
        if self.range is not None and not self.range[0] <= self.range[1]:
            raise ValueError(f"parameter spec {self.name!r}: empty range {self.range}")
        if self.choices and self.kind != "string":
            raise ValueError(f"parameter spec {self.name!r}: choices need a string default")
        try:
            self.validate(self.default)
        except ParamValueError as exc:
            raise ValueError(f"parameter spec {self.name!r}: default {self.default!r}: {exc.reason}") from None

    @property
    def kind(self) -> str:
        """The type's name: ``bool``, ``integer``, ``double``, ``string`` or ``string list``."""
        if isinstance(self.default, bool):
            return "bool"
        if isinstance(self.default, int):
            return "integer"
        if isinstance(self.default, float):
            return "double"
        if isinstance(self.default, str):
            return "string"
        return "string list"

    def bound_text(self, x: float) -> str:
        """A bound as messages show it: an integer's digits, a double with ``:g``."""
        return str(int(x)) if self.kind == "integer" else f"{x:g}"

    @property
    def range_text(self) -> str:
        """The range as an interval, e.g. ``[0.001, 1000]`` or ``(0, 1]``; "" without one."""
        if self.range is None:
            return ""
        low, high = self.range
        return f"{'(' if self.open_low else '['}{self.bound_text(low)}, {self.bound_text(high)}]"

    def _check_range(self, x: float) -> None:
        if self.range is None:
            return
        low, high = self.range
        if x < low or (self.open_low and x == low):
            raise ParamRangeError(f"must be {'>' if self.open_low else '>='} {self.bound_text(low)}")
        if x > high:
            raise ParamRangeError(f"must be <= {self.bound_text(high)}")

    def validate(self, value: object) -> ParamValue:
        """The value, checked and converted to the spec's type.

        An integer is accepted for a double (and converted); with ``loose_type`` one string is
        accepted for a string list. Strings are taken as they are (a reader strips them first
        if it wants to).

        Args:
            value: The value given.

        Returns:
            The value as the spec's type (a tuple for a string list).

        Raises:
            ParamTypeError: The wrong type (``expected a string``, ``expected a number``...).
            ParamRangeError: A number outside the range (``must be >= 0``, ``must be <= 1000``).
            ParamValueError: A double that is not finite, or a string not among the choices.
        """
        kind = self.kind
        if kind == "bool":
            if not isinstance(value, bool):
                raise ParamTypeError("expected true or false")
            return value
        if kind == "string":
            return self._validate_string(value)
        if kind == "string list":
            return self._validate_list(value)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParamTypeError("expected a whole number" if kind == "integer" else "expected a number")
        if kind == "integer":
            if not isinstance(value, int):
                raise ParamTypeError("expected a whole number")
            self._check_range(value)
            return value
        x = float(value)
        if not math.isfinite(x):
            raise ParamValueError("must be finite")
        self._check_range(x)
        return x

    def _validate_string(self, value: object) -> str:
        if not isinstance(value, str):
            raise ParamTypeError("expected a string")
        if self.choices and value not in self.choices:
            raise ParamValueError(f"expected one of {', '.join(self.choices)}")
        return value

    def _validate_list(self, value: object) -> tuple[str, ...]:
        if self.loose_type and isinstance(value, str):
            return (value,)
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
            raise ParamTypeError("expected a list of strings")
        return tuple(value)


def merge_specs(*groups: Iterable[ParamSpec]) -> tuple[ParamSpec, ...]:
    """The specs of several groups, each name once, in first-seen order.

    A spec shared by several groups (``time_scale`` of the sim, bag and CAN sources) must be
    the same object or equal in every group.

    Raises:
        ValueError: Two different specs of one name (a programming error).
    """
    merged: dict[str, ParamSpec] = {}
    for group in groups:
        for spec in group:
            seen = merged.setdefault(spec.name, spec)
            if seen != spec:
                raise ValueError(f"parameter {spec.name!r} is specified twice, differently: {seen} and {spec}")
    return tuple(merged.values())
