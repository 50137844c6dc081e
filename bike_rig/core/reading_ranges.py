"""The plausible range of every reading and benchmark parameter, and the unit mistakes that explain a value outside it.

One table for every input boundary (console, measurement and parameter readers, ``replay
--readings``), wide enough for every bicycle of the paper and of ``../shared/data``.
:func:`unit_mistakes` finds the out-of-range values a wrong unit explains (mm, grams, radians),
each a :class:`UnitMistake` with the likely unit and corrected value; the rest is left to
:mod:`bike_rig.core.plausibility` and the readers. ROS-free. SI; degrees only in ``gamma`` and
``alpha*`` (readings), ``lam`` in rad.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

from .errors import BikeRigError

__all__ = [
    "COUNT_KEYS",
    "PARAMETER_RANGES",
    "RADIUS_RANGE",
    "READING_RANGES",
    "TRAIL_RANGE",
    "PlausibleRange",
    "UnitMistake",
    "UnitMistakeWarning",
    "parameter_unit_mistakes",
    "plausible_range",
    "reading_unit",
    "unit_mistakes",
]

#: The exact counts: whole numbers with σ 0.
COUNT_KEYS: tuple[str, ...] = ("nR", "nF")

#: Plausible wheel radius, m (a 12-inch child's wheel to a 36-inch wheel, with room).
RADIUS_RANGE: tuple[float, float] = (0.1, 0.8)
#: Plausible trail c, m (Eq 8; the paper's bicycles: 0.047-0.18 m, Yellowrev's reversed fork the largest).
TRAIL_RANGE: tuple[float, float] = (-0.15, 0.4)

# Unit mistakes tried, in order: (what it looks like, factor to the key's unit).
LENGTH_UNITS: tuple[tuple[str, float], ...] = (("millimetres", 1e-3), ("centimetres", 1e-2), ("inches", 0.0254))
MASS_UNITS: tuple[tuple[str, float], ...] = (("grams", 1e-3), ("pounds", 0.45359237))
GRAVITY_UNITS: tuple[tuple[str, float], ...] = (("ft/s²", 0.3048), ("cm/s²", 1e-2))
#: A head-tube angle typed in radians, read as degrees.
RADIAN_UNITS: tuple[tuple[str, float], ...] = (("radians", 180.0 / math.pi),)
#: A steer-axis tilt typed in degrees, read as radians.
DEGREE_UNITS: tuple[tuple[str, float], ...] = (("degrees", math.pi / 180.0),)

_ORIENTATION_KEY = re.compile(r"^(alpha|a)([BHSG])([1-9]\d*)$")


class UnitMistakeWarning(BikeRigError, UserWarning):
    """A value outside its plausible range that a wrong unit explains (:class:`UnitMistake`).

    A warning (``warnings.warn``) where it is found; raised as an error (one line, exit status 2)
    when warnings of this class are errors (``bike-rig ... --strict``).
    """


@dataclass(frozen=True)
class PlausibleRange:
    """The values a key plausibly takes on any bicycle, and how it is mistyped.

    Attributes:
        low: Smallest plausible value, in the key's unit.
        high: Largest plausible value.
        what: What the reading is, for messages (e.g. ``"front wheel mass"``).
        units: Wrong units to try on an implausible value: (name, factor to the key's unit).
    """

    low: float
    high: float
    what: str
    units: tuple[tuple[str, float], ...] = ()

    def holds(self, value: float) -> bool:
        """Whether ``value`` lies in [low, high]."""
        return self.low <= value <= self.high


#: The static readings' ranges (the orientation readings ``alpha*``/``a*``: :func:`plausible_range`).
READING_RANGES: dict[str, PlausibleRange] = {
    "g": PlausibleRange(9.76, 9.84, "gravity", GRAVITY_UNITS),
    "w": PlausibleRange(0.5, 2.5, "wheelbase", LENGTH_UNITS),
    "gamma": PlausibleRange(45.0, 85.0, "head-tube angle"),
    "f": PlausibleRange(-0.15, 0.15, "fork offset", LENGTH_UNITS),
    "mR": PlausibleRange(0.5, 10.0, "rear wheel mass", MASS_UNITS),
    "mF": PlausibleRange(0.5, 10.0, "front wheel mass", MASS_UNITS),
    "mB": PlausibleRange(2.0, 40.0, "frame mass", MASS_UNITS),
    "mH": PlausibleRange(0.5, 10.0, "fork and handlebar mass", MASS_UNITS),
    "mP": PlausibleRange(0.5, 20.0, "calibration rod mass", MASS_UNITS),
    "lR": PlausibleRange(0.05, 0.8, "rear wheel pendulum arm", LENGTH_UNITS),
    "lF": PlausibleRange(0.05, 0.8, "front wheel pendulum arm", LENGTH_UNITS),
    "lP": PlausibleRange(0.2, 3.0, "calibration rod length", LENGTH_UNITS),
    "dP": PlausibleRange(0.003, 0.1, "calibration rod diameter", LENGTH_UNITS),
    "nR": PlausibleRange(1.0, 100.0, "rear wheel rotations"),
    "nF": PlausibleRange(1.0, 100.0, "front wheel rotations"),
    "dR": PlausibleRange(0.5, 200.0, "rear wheel distance rolled", LENGTH_UNITS),
    "dF": PlausibleRange(0.5, 200.0, "front wheel distance rolled", LENGTH_UNITS),
    # the refined method: fork and handlebar hung separately, geometry from a surface plate
    "mS": PlausibleRange(0.2, 10.0, "fork mass", MASS_UNITS),
    "mG": PlausibleRange(0.2, 10.0, "handlebar mass", MASS_UNITS),
    "mD": PlausibleRange(0.5, 40.0, "front wheel with its flywheel, mass", MASS_UNITS),
    **{f"h{i}": PlausibleRange(0.0, 2.0, "surface-plate height", LENGTH_UNITS) for i in range(1, 8)},
    **{f"d{i}": PlausibleRange(0.001, 0.1, "surface-plate diameter", LENGTH_UNITS) for i in range(1, 7)},
    "d": PlausibleRange(0.3, 2.5, "distance between the axles on the surface plate", LENGTH_UNITS),
    "l": PlausibleRange(0.05, 2.0, "front axle to handlebar reference distance", LENGTH_UNITS),
}
#: Hanging angle of the head / steer tube, degree (as the digital level reads it).
ALPHA_RANGE = PlausibleRange(0.0, 360.0, "hanging angle")
#: String-line distance to the axle, m (the paper's bicycles: |a| up to 0.52 m).
DISTANCE_RANGE = PlausibleRange(-1.0, 1.0, "string-line distance to the axle", LENGTH_UNITS)

#: The benchmark parameters' ranges, where they are the readings' quantities (SI, lam in rad). mB
#: and mH are wider than the readings': a benchmark set may hold a rigid rider in the rear frame
#: (Meijaard et al. 2007, Table 1: mB = 85 kg).
PARAMETER_RANGES: dict[str, PlausibleRange] = {
    "g": READING_RANGES["g"],
    "w": READING_RANGES["w"],
    "c": PlausibleRange(*TRAIL_RANGE, "trail", LENGTH_UNITS),
    "rR": PlausibleRange(*RADIUS_RANGE, "rear wheel radius", LENGTH_UNITS),
    "rF": PlausibleRange(*RADIUS_RANGE, "front wheel radius", LENGTH_UNITS),
    # the head-tube angles of READING_RANGES (45 to 85°) as the tilt from the vertical, 5 to 45°
    "lam": PlausibleRange(math.radians(5.0), math.radians(45.0), "steer-axis tilt", DEGREE_UNITS),
    "mR": READING_RANGES["mR"],
    "mF": READING_RANGES["mF"],
    "mB": PlausibleRange(2.0, 150.0, "rear frame mass (a rider included)", MASS_UNITS),
    "mH": PlausibleRange(0.5, 20.0, "fork and handlebar mass", MASS_UNITS),
}


def plausible_range(key: str) -> PlausibleRange | None:
    """The plausible range of static reading ``key`` (None for a key that is not one)."""
    if key in READING_RANGES:
        return READING_RANGES[key]
    if _ORIENTATION_KEY.match(key) is None:
        return None
    return ALPHA_RANGE if key.startswith("alpha") else DISTANCE_RANGE


def reading_unit(key: str) -> str:
    """The unit of a reading: ``deg``, ``kg``, ``m/s^2``, ``1`` (counts), ``s`` (periods) or ``m``."""
    if key == "gamma" or key.startswith("alpha"):
        return "deg"
    if key in COUNT_KEYS:
        return "1"
    if key == "g":
        return "m/s^2"
    if re.match(r"^T[ct][A-Z]\d+$", key):
        return "s"
    return "kg" if key.startswith("m") else "m"


_PARAMETER_UNITS = {"g": "m/s^2", "lam": "rad", "mR": "kg", "mF": "kg", "mB": "kg", "mH": "kg"}


@dataclass(frozen=True)
class UnitMistake:
    """A value outside its plausible range that a wrong unit explains.

    Attributes:
        key: The reading or parameter.
        value: The value given, in the key's unit.
        unit: The key's unit (``m``, ``kg``, ``deg``...).
        rng: Its plausible range.
        likely: The units that explain it (``millimetres``...), most likely first.
        corrected: The value in the key's unit, read in each likely unit.
    """

    key: str
    value: float
    unit: str
    rng: PlausibleRange
    likely: tuple[str, ...]
    corrected: tuple[float, ...]

    def __str__(self) -> str:
        """``w = 1021 m is outside the plausible wheelbase (0.5 to 2.5 m): it looks like millimetres (w = 1.021 m)``."""
        fits = " or ".join(f"{name} ({self.key} = {v:.6g} {self.unit})" for name, v in zip(self.likely, self.corrected))
        return (
            f"{self.key} = {self.value:g} {self.unit} is outside the plausible {self.rng.what} "
            f"({self.rng.low:g} to {self.rng.high:g} {self.unit}): it looks like {fits}"
        )


def _mistake(key: str, value: float, rng: PlausibleRange | None, unit: str) -> UnitMistake | None:
    if rng is None or not math.isfinite(value) or rng.holds(value):
        return None
    fits = [(name, value * factor) for name, factor in rng.units if rng.holds(value * factor)]
    if not fits:
        return None
    return UnitMistake(key, value, unit, rng, tuple(n for n, _ in fits), tuple(v for _, v in fits))


def _gamma_range() -> PlausibleRange:
    g = READING_RANGES["gamma"]
    return PlausibleRange(g.low, g.high, g.what, RADIAN_UNITS)


def unit_mistakes(readings: Mapping[str, float]) -> list[UnitMistake]:
    """The static readings outside their range that a wrong unit explains, in the readings' order.

    Args:
        readings: Values by flat key, in the key's unit (:func:`reading_unit`); other keys (periods) are skipped.
    """
    out = []
    for key, value in readings.items():
        rng = _gamma_range() if key == "gamma" else plausible_range(key)
        found = _mistake(key, float(value), rng, reading_unit(key))
        if found is not None:
            out.append(found)
    return out


def parameter_unit_mistakes(values: Mapping[str, float]) -> list[UnitMistake]:
    """The benchmark parameters outside their range that a wrong unit explains (a wheelbase in mm, lam in degrees)."""
    out = []
    for key, rng in PARAMETER_RANGES.items():
        if key in values:
            found = _mistake(key, float(values[key]), rng, _PARAMETER_UNITS.get(key, "m"))
            if found is not None:
                out.append(found)
    return out
