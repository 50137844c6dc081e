"""Records of one bicycle's raw readings (value ± σ) and their validation.

Readings are stored flat under BicycleParameters' ``Measured.txt`` key names (``g``, ``w``,
``gamma``, ``TtB2``..., listed with units in ``docs/formats.md``), whatever file they came from.
The geometry is given directly (``w``, ``gamma``, ``f``) or by a surface plate (``h1``…``h5``,
``d1``…``d4``, ``d``); the front assembly is hung as one part ``H`` or as fork ``S`` and
handlebar ``G``. Plate readings of 0 have meanings (:mod:`bike_rig.core.surface_plate`) and are
checked together (:func:`check_surface_plate`). Degrees occur only in ``gamma`` and ``alpha*``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from . import geometry, split_fork, surface_plate
from .errors import MeasurementError

__all__ = [
    "COMMON_KEYS",
    "DIRECT_GEOMETRY_KEYS",
    "FLYWHEEL_KEYS",
    "FORK_KEYS",
    "KNOWN_KEYS",
    "PART_NAMES",
    "SPLIT_FORK_KEYS",
    "SURFACE_PLATE_KEYS",
    "fork_is_split",
    "has_flywheel",
    "geometry_from_surface_plate",
    "hung_parts",
    "is_period_key",
    "missing_reason",
    "required_keys",
    "Measurements",
    "Origin",
    "Reading",
    "REQUIRED_KEYS",
    "MAX_MAGNITUDE",
    "PLATE_TOLERANCE_SIGMAS",
    "SurfacePlateError",
    "check_reading",
    "check_surface_plate",
    "check_value_sigma",
    "orientation_indices",
    "validate",
]

#: Keys a measurement set of the paper's method needs (orientation keys are checked separately).
REQUIRED_KEYS: tuple[str, ...] = (
    "g",
    "w",
    "gamma",
    "f",
    "nR",
    "dR",
    "mR",
    "lR",
    "TcR1",
    "TtR1",
    "nF",
    "dF",
    "mF",
    "lF",
    "TcF1",
    "TtF1",
    "mB",
    "TcB1",
    "mH",
    "TcH1",
    "mP",
    "lP",
    "dP",
    "TtP1",
)
#: The geometry given directly (the paper's method).
DIRECT_GEOMETRY_KEYS: tuple[str, ...] = ("w", "gamma", "f")
#: The geometry measured on a surface plate (refined method), instead of DIRECT_GEOMETRY_KEYS.
SURFACE_PLATE_KEYS: tuple[str, ...] = ("h1", "h2", "h3", "h4", "h5", "d1", "d2", "d3", "d4", "d")
#: The front assembly hung as one part (the paper's method).
FORK_KEYS: tuple[str, ...] = ("mH", "TcH1")
#: The fork S and handlebar G hung separately, with the handlebar's pivot (refined method).
SPLIT_FORK_KEYS: tuple[str, ...] = ("mS", "TcS1", "mG", "TcG1", "h6", "h7", "d5", "d6", "l")
#: An extra rigid part on the front wheel, a flywheel D: the mass and periods of the wheel with it.
FLYWHEEL_KEYS: tuple[str, ...] = ("mD", "TcD1", "TtD1")
#: Keys every measurement set needs whatever its method.
COMMON_KEYS: tuple[str, ...] = tuple(k for k in REQUIRED_KEYS if k not in DIRECT_GEOMETRY_KEYS and k not in FORK_KEYS)
#: Every non-orientation key the science reads (the readings a file reader keeps as numbers).
KNOWN_KEYS: frozenset[str] = frozenset(REQUIRED_KEYS + SURFACE_PLATE_KEYS + SPLIT_FORK_KEYS + FLYWHEEL_KEYS)
#: Keys that must be strictly positive.
_POSITIVE = re.compile(r"^(g|w|n[RF]|d[RF]|m[RFBHPSGD]|l[RFP]|dP|T[ct][RFBHPSGD]\d+)$")
#: Surface-plate heights, diameters and distances: never negative, and 0 has a meaning (see
#: :mod:`bike_rig.core.surface_plate`); what they may be is decided by :func:`check_surface_plate`.
_PLATE = re.compile(r"^(h[1-7]|d[1-6]?|l)$")
#: How far, in combined σ of its readings, a tube may seem to sink into the surface plate before
#: its readings are refused (a tube resting on the plate reads top = diameter, up to their errors).
PLATE_TOLERANCE_SIGMAS = 3.0
#: Each tube or axle lying on the surface plate: the keys summing to its top, its diameter, its name.
_PLATE_TUBES: tuple[tuple[tuple[str, ...], str, str], ...] = (
    (("h1", "h2"), "d2", "the dummy rear axle"),
    (("h3",), "d1", "the head tube"),
    (("h4",), "d3", "the dummy front axle"),
    (("h5",), "d4", "the steer tube"),
)
#: The same for the handlebar reference fixture of a split fork.
_HANDLEBAR_TUBES: tuple[tuple[tuple[str, ...], str, str], ...] = (
    (("h6",), "d5", "the front axle (handlebar fixture)"),
    (("h7",), "d6", "the handlebar reference circle"),
)
#: Names of the parts hung as pendulums at several orientations, for messages.
PART_NAMES = {"B": "frame", "H": "fork", "S": "fork (S)", "G": "handlebar (G)"}
#: Exact counts.
_COUNTS = ("nR", "nF")
#: The largest magnitude a reading or its σ may have, in its unit (SI, or degrees): far beyond
#: any rig's (the largest, a distance rolled, is some tens of m), and small enough that the
#: products of a few readings in the equations cannot overflow a float.
MAX_MAGNITUDE = 1e9
#: Minimum number of hanging orientations of the frame and of the fork (Eq 35 needs 3).
MIN_ORIENTATIONS = 3


class SurfacePlateError(MeasurementError):
    """Surface-plate readings no bicycle lying on the plate can give (a tube in the plate, an open triangle)."""


@dataclass(frozen=True)
class Origin:
    """Where a reading came from, for error messages.

    Attributes:
        path: The file as given by the user.
        key: The key as written in that file (e.g. ``frame.orientations[2].angle_deg``).
        line: 1-based line number, or None if unknown.
    """

    path: str
    key: str
    line: int | None = None


@dataclass(frozen=True)
class Reading:
    """One measured value with its standard uncertainty.

    Attributes:
        value: The value, in the unit of its key (``docs/formats.md``).
        sigma: Its standard deviation, same unit; 0 for exact values.
        origin: Where it was read.
    """

    value: float
    sigma: float
    origin: Origin | None = None

    def error(self, reason: str) -> MeasurementError:
        """A :class:`MeasurementError` pointing at this reading."""
        o = self.origin or Origin("<memory>", "?")
        return MeasurementError(o.path, reason, key=o.key, line=o.line)


@dataclass(frozen=True)
class Measurements:
    """All raw readings of one bicycle.

    Attributes:
        bicycle: The bicycle's name.
        readings: Readings keyed by the flat key names (``docs/formats.md``).
        path: The file they were read from.
        extras: Entries of the file that the 25 parameters do not need (e.g. rider
            geometry), kept verbatim so that nothing recorded is lost on conversion.
        evidence: For periods computed from raw trial files: key -> the trials, their fits
            and the combination (a :class:`bike_rig.core.trial_periods.PeriodEvidence`).
    """

    bicycle: str
    readings: Mapping[str, Reading]
    path: str = "<memory>"
    extras: Mapping[str, object] = field(default_factory=dict)
    evidence: Mapping[str, Any] = field(default_factory=dict)

    def value(self, key: str) -> float:
        """The value of reading ``key``."""
        return self.readings[key].value

    def orientations(self, part: str) -> list[int]:
        """The orientation indices of ``part`` ('B' frame, 'H' fork, 'S' or 'G'), in order."""
        return orientation_indices(self.readings, part)


def is_period_key(key: str) -> bool:
    """True for pendulum-period keys (``Tc*``, ``Tt*``), the readings live trials provide."""
    return key.startswith(("Tc", "Tt"))


def orientation_indices(readings: Mapping[str, object], part: str) -> list[int]:
    """Sorted indices ``i`` for which any of ``alpha<part><i>``, ``a<part><i>`` exists."""
    pattern = re.compile(rf"^(alpha|a|Tt){part}(\d+)$")
    found = {int(m.group(2)) for k in readings if (m := pattern.match(k))}
    return sorted(found)


def check_value_sigma(value: float, sigma: float) -> None:
    """Check that a value and its σ are numbers a reading can have, whatever its key.

    Both finite, σ ≥ 0, and neither beyond :data:`MAX_MAGNITUDE` (in the reading's unit).

    Raises:
        ValueError: the reason, in one line.
    """
    if not (math.isfinite(value) and math.isfinite(sigma)):
        raise ValueError(f"value and sigma must be finite numbers, got {value:g} ± {sigma:g}")
    if sigma < 0:
        raise ValueError(f"sigma must be >= 0, got {sigma:g}")
    for what, x in (("value", value), ("sigma", sigma)):
        if abs(x) > MAX_MAGNITUDE:
            raise ValueError(f"{what} {x:g} is beyond any plausible reading (magnitude above {MAX_MAGNITUDE:g})")


def check_reading(key: str, r: Reading) -> None:
    """Check that one reading is physically possible for its key (units as in ``docs/formats.md``).

    Raises:
        MeasurementError: naming the reading's origin and the reason.
    """
    try:
        check_value_sigma(r.value, r.sigma)
    except ValueError as exc:
        raise r.error(str(exc)) from None
    if _POSITIVE.match(key) and r.value <= 0:
        raise r.error(f"must be positive, got {r.value:g}")
    if _PLATE.match(key) and r.value < 0:
        raise r.error(f"a surface-plate height, diameter or distance cannot be negative, got {r.value:g}")
    if key in _COUNTS and (r.value != round(r.value) or r.sigma != 0):
        raise r.error(f"a number of rotations is an exact whole count, got {r.value:g} ± {r.sigma:g}")
    if key == "gamma" and not 0 < r.value <= 90:
        raise r.error(f"head-tube angle must be in (0, 90] degrees from the horizontal, got {r.value:g}")
    if key.startswith("alpha") and not -360 <= r.value <= 360:
        raise r.error(f"hanging angle must be in [-360, 360] degrees, got {r.value:g}")


def _plate_error(r: Reading, reason: str) -> SurfacePlateError:
    o = r.origin or Origin("<memory>", "?")
    return SurfacePlateError(o.path, reason, key=o.key, line=o.line)


def _check_tubes(readings: Mapping[str, Reading], tubes: tuple[tuple[tuple[str, ...], str, str], ...]) -> None:
    """Each tube's top at least its diameter above the plate, within the readings' σ."""
    for tops, diameter, name in tubes:
        top = sum(readings[k].value for k in tops)
        d = readings[diameter].value
        tolerance = PLATE_TOLERANCE_SIGMAS * math.sqrt(sum(readings[k].sigma ** 2 for k in (*tops, diameter)))
        if surface_plate.tube_clearance(top, d) < -tolerance:
            raise _plate_error(
                readings[tops[0]],
                f"{name} would sink into the surface plate: its top is {top:g} m above the plate "
                f"({' + '.join(tops)}) but its diameter ({diameter}) is {d:g} m; a height is read to the "
                f"top of the tube, or to its axis when its diameter is given as 0",
            )


def check_surface_plate(m: Measurements) -> None:
    """Check that surface-plate readings describe a bicycle that can lie on the plate.

    Zeros are allowed where they mean something (:mod:`bike_rig.core.surface_plate`); what is
    refused is geometry: a tube or axle below the plate (top less than its diameter, beyond
    :data:`PLATE_TOLERANCE_SIGMAS` σ), axle centres closer than their offsets across the steer axis
    (no c_s), a non-positive a + b, wheels whose radii differ by more than the axles' distance, and
    for a split fork a handlebar reference closer to the axle than its offset l1 (no l2).
    Needs every key of :func:`required_keys` (call after checking that none is missing).

    Raises:
        SurfacePlateError: naming the file, line and key of the reading most directly at fault.
    """
    r = m.readings
    v = {k: x.value for k, x in r.items()}
    if geometry_from_surface_plate(r):
        _check_tubes(r, _PLATE_TUBES)
        a = surface_plate.rear_frame_offset(v["h1"], v["h2"], v["h3"], v["d1"], v["d2"])
        b = surface_plate.fork_offset(v["h4"], v["h5"], v["d3"], v["d4"])
        hyp = surface_plate.axle_centre_distance(v["d"], v["d2"], v["d3"])
        if not hyp > abs(a - b):
            raise _plate_error(
                r["d"],
                f"the axle centres, the fork reversed, are {hyp:g} m apart (d + (d2 + d3)/2), not more "
                f"than their offsets across the steer axis differ (|a - b| = {abs(a - b):g} m): no "
                "steer-axis distance c_s closes that triangle",
            )
        if not a + b > 0:
            raise _plate_error(
                r["h1"],
                f"the rear-frame offset a = {a:g} m and the fork offset b = {b:g} m must put the axles on "
                f"either side of the steer axis (a + b > 0), got a + b = {a + b:g} m",
            )
        c_s = surface_plate.steer_axis_distance(a, b, v["d"], v["d2"], v["d3"])
        reach = math.hypot(a + b, c_s)
        dr = geometry.wheel_radius(v["dF"], v["nF"]) - geometry.wheel_radius(v["dR"], v["nR"])
        if not abs(dr) < reach:
            raise _plate_error(
                r["d"],
                f"the wheel radii differ by {abs(dr):g} m, more than the axles' spread "
                f"sqrt((a + b)^2 + c_s^2) = {reach:g} m: no steer-axis tilt puts both wheels on the ground",
            )
    if fork_is_split(r):
        _check_tubes(r, _HANDLEBAR_TUBES)
        l1 = split_fork.handlebar_normal_offset(v["h6"], v["h7"], v["d5"], v["d6"])
        l0 = split_fork.handlebar_centre_distance(v["l"], v["d5"], v["d6"])
        if not l0 > abs(l1):
            raise _plate_error(
                r["l"],
                f"the handlebar reference centre is {l0:g} m from the front axle centre (l - (d5 + d6)/2), "
                f"not more than its offset across the steer axis (|l1| = {abs(l1):g} m, from h6, h7, d5, d6)",
            )


def geometry_from_surface_plate(readings: Mapping[str, object]) -> bool:
    """True when the geometry comes from the surface plate (no ``w`` given, as BicycleParameters decides)."""
    return "w" not in readings and any(k in readings for k in SURFACE_PLATE_KEYS)


def fork_is_split(readings: Mapping[str, object]) -> bool:
    """True when the fork ``S`` and handlebar ``G`` were hung separately (any of their readings given)."""
    pattern = re.compile(r"^(m|Tc|Tt|alpha|a)[SG]\d*$")
    return any(pattern.match(k) for k in readings)


def has_flywheel(readings: Mapping[str, object]) -> bool:
    """True when a flywheel D on the front wheel was measured (any of its readings given)."""
    return any(k in readings for k in FLYWHEEL_KEYS)


def hung_parts(readings: Mapping[str, object]) -> str:
    """The parts hung at several orientations: ``"BH"`` (paper), or ``"BSG"`` (fork split)."""
    return "BSG" if fork_is_split(readings) else "BH"


def required_keys(readings: Mapping[str, object]) -> tuple[str, ...]:
    """The non-orientation keys needed for the methods ``readings`` use (geometry, front assembly)."""
    geometry = SURFACE_PLATE_KEYS if geometry_from_surface_plate(readings) else DIRECT_GEOMETRY_KEYS
    front = SPLIT_FORK_KEYS if fork_is_split(readings) else FORK_KEYS
    return COMMON_KEYS + geometry + front + (FLYWHEEL_KEYS if has_flywheel(readings) else ())


def missing_reason(key: str) -> str:
    """Why ``key`` is needed, naming the other way of measuring where there is one."""
    if key in DIRECT_GEOMETRY_KEYS:
        return (
            "missing: the geometry needs either the wheelbase, head-tube angle and fork offset "
            "(w, gamma, f) or the surface-plate heights and diameters (h1..h5, d1..d4, d)"
        )
    if key in SURFACE_PLATE_KEYS:
        return "missing: the surface-plate geometry (no 'w' given) needs h1..h5, d1..d4 and d"
    if key in SPLIT_FORK_KEYS:
        return (
            "missing: the fork (S) and handlebar (G) measured separately need mS, TcS1, mG, TcG1 "
            "and the handlebar reference h6, h7, d5, d6, l"
        )
    if key in FLYWHEEL_KEYS:
        return (
            "missing: a flywheel D on the front wheel needs mD (the front wheel with it), and that "
            "wheel's compound and torsional periods TcD1, TtD1"
        )
    return "missing (needed for the benchmark parameters)"


def validate(m: Measurements) -> None:
    """Check that ``m`` has every reading the 25 parameters need, each physically possible.

    Raises:
        MeasurementError: naming the file, key, line and reason of the first problem.
    """
    for key in required_keys(m.readings):
        if key not in m.readings:
            raise MeasurementError(m.path, missing_reason(key), key=key)
    for key, r in m.readings.items():
        check_reading(key, r)
    check_surface_plate(m)
    parts = hung_parts(m.readings)
    if parts == "BSG":
        for key in ("mH", "TcH1", *(f"{p}H{i}" for p in ("alpha", "a", "Tt") for i in m.orientations("H"))):
            if key in m.readings:
                raise m.readings[key].error(
                    "the fork and handlebar were measured separately (S, G readings given), so the "
                    "combined fork/handlebar H must not be measured too: remove one of the two"
                )
    for part in parts:
        name = PART_NAMES[part]
        idx = m.orientations(part)
        for i in idx:
            for prefix in ("alpha", "a", "Tt"):
                if f"{prefix}{part}{i}" not in m.readings:
                    raise MeasurementError(
                        m.path, f"{name} orientation {i} lacks this reading", key=f"{prefix}{part}{i}"
                    )
        if len(idx) < MIN_ORIENTATIONS:
            raise MeasurementError(
                m.path,
                f"{name}: {len(idx)} hanging orientation(s) given, at least {MIN_ORIENTATIONS} are "
                "needed for the inertia tensor (Eq 35)",
                key=f"alpha{part}",
            )
