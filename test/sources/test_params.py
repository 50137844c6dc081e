"""Parameter specs (bike_rig.config.settings) and the backends' own parameters.

Read through ``sources.base.Parameters``: defaults, ranges and choices are defined once, by each backend.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import pytest

from bike_rig.config.settings import ParamRangeError, ParamSpec, ParamTypeError, ParamValueError, merge_specs
from bike_rig.sources import BACKENDS, SourceConfigError, backend_parameters, source_class
from bike_rig.sources.base import SAMPLE_RATE, TIME_SCALE, GyroSource, Parameters, SourceEvent


def test_spec_kinds_ranges_and_messages() -> None:
    count = ParamSpec("n", 4, "samples", (1, 64))
    assert (count.kind, count.range_text) == ("integer", "[1, 64]")
    assert count.validate(64) == 64
    with pytest.raises(ParamRangeError, match=r"^must be >= 1$"):
        count.validate(0)
    with pytest.raises(ParamRangeError, match=r"^must be <= 64$"):
        count.validate(65)
    for bad in (4.0, True, "4"):
        with pytest.raises(ParamTypeError, match=r"^expected a whole number$"):
            count.validate(bad)
    period = ParamSpec("flush", 0.5, "s", (0.0, 1.0), open_low=True)
    assert (period.kind, period.range_text) == ("double", "(0, 1]")
    assert period.validate(1) == 1.0 and isinstance(period.validate(1), float)
    with pytest.raises(ParamRangeError, match=r"^must be > 0$"):
        period.validate(0.0)
    with pytest.raises(ParamValueError, match=r"^must be finite$"):
        period.validate(math.nan)
    with pytest.raises(ParamTypeError, match=r"^expected a number$"):
        period.validate(False)
    choice = ParamSpec("order", "little", "byte order", choices=("little", "big"))
    assert choice.validate("big") == "big"
    with pytest.raises(ParamValueError, match=r"^expected one of little, big$"):
        choice.validate("middle")
    with pytest.raises(ParamTypeError, match=r"^expected true or false$"):
        ParamSpec("fd", False, "flag").validate(0)
    names = ParamSpec("topics", ("all",), "names", loose_type=True)
    assert (names.kind, names.validate("gyro"), names.validate(["a", "b"])) == ("string list", ("gyro",), ("a", "b"))
    with pytest.raises(ParamTypeError, match=r"^expected a list of strings$"):
        ParamSpec("topics", ("all",), "names").validate("gyro")


@pytest.mark.parametrize(
    "kwargs",
    [
        {"default": "x", "range": (0.0, 1.0)},
        {"default": 1.0, "choices": ("a",)},
        {"default": 2.0, "range": (0.0, 1.0)},
        {"default": "c", "choices": ("a", "b")},
        {"default": 1.0, "range": (1.0, 0.0)},
    ],
)
def test_inconsistent_specs_are_refused(kwargs: dict[str, Any]) -> None:
    with pytest.raises(ValueError, match=r"^parameter spec 'p'"):
        ParamSpec("p", description="", **kwargs)


def test_merge_keeps_one_spec_per_name_and_refuses_conflicts() -> None:
    a, b = ParamSpec("a", 1, ""), ParamSpec("b", "", "")
    assert merge_specs((a, TIME_SCALE), (TIME_SCALE, b)) == (a, TIME_SCALE, b)
    with pytest.raises(ValueError, match=r"'time_scale' is specified twice"):
        merge_specs((TIME_SCALE,), (ParamSpec("time_scale", 2.0, "other"),))


def test_every_backend_declares_its_parameters_once() -> None:
    union = backend_parameters()
    names = [s.name for s in union]
    assert len(names) == len(set(names))
    for name in BACKENDS:
        specs = source_class(name).PARAMETERS
        assert specs, f"the {name} source declares no parameters"
        assert set(s.name for s in specs) <= set(names)
    assert TIME_SCALE in source_class("sim").PARAMETERS and TIME_SCALE in source_class("bag").PARAMETERS
    assert SAMPLE_RATE in source_class("can").PARAMETERS and SAMPLE_RATE in source_class("daq").PARAMETERS
    assert {"source", "frame_id"}.isdisjoint(names)  # the driver's own


def test_reader_uses_the_specs_defaults_ranges_and_choices() -> None:
    specs = (ParamSpec("mode", "a", "", choices=("a", "b")), ParamSpec("n", 3, "", (0, 10)), TIME_SCALE)
    p = Parameters("toy", {"mode": " b ", "unknown": 1}, specs)
    assert (p.text("mode"), p.integer("n"), p.number("time_scale")) == ("b", 3, 1.0)
    with pytest.raises(SourceConfigError, match=r"^toy source: parameter 'time_scale' = 5000.0: must be <= 1000$"):
        Parameters("toy", {"time_scale": 5000.0}, specs).number("time_scale")
    with pytest.raises(SourceConfigError, match=r"^toy source: parameter 'mode' = 'c': expected one of a, b$"):
        Parameters("toy", {"mode": "c"}, specs).text("mode")
    with pytest.raises(KeyError, match="declares no double parameter 'n'"):
        p.number("n")


class _ToySource(GyroSource):
    """A backend as a new gyro source would be written: one class with its own parameters."""

    name = "toy"
    PARAMETERS: ClassVar[tuple[ParamSpec, ...]] = (ParamSpec("toy_level", 1.0, "toy: level, rad/s", (0.0, 2.0)),)

    def __init__(self, level: float):
        self.level = level

    @classmethod
    def from_parameters(cls, parameters: Any) -> _ToySource:
        return cls(Parameters(cls.name, parameters, cls.PARAMETERS).number("toy_level"))

    def poll(self) -> list[SourceEvent]:
        return []


def test_a_new_backend_is_one_class_and_one_registry_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(BACKENDS, "toy", f"{__name__}:_ToySource")
    assert _ToySource.PARAMETERS[0] in backend_parameters()
    from bike_rig.sources import open_source

    assert open_source("toy", toy_level=0.5).level == 0.5
    with pytest.raises(SourceConfigError, match=r"^toy source: parameter 'toy_level' = 3.0: must be <= 2$"):
        open_source("toy", toy_level=3.0)
