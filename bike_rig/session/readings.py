"""A static reading as the operator types it: parsed, checked, and looked at for likely mistakes.

Without ROS: :func:`parse_reading` turns a typed key, value and σ into a
:class:`~bike_rig.pipeline.readings.ReadingEntry` or refuses it in one line
(:class:`ReadingInputError`); :func:`plausibility` warns, one line each, about a value that is
possible but probably wrong. Keys are the static keys of ``docs/formats.md`` (periods come from
trials). Units: SI; degrees only in ``gamma`` and ``alpha*``; σ in the key's unit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterator, Mapping

from ..core import geometry
from ..core.errors import BikeRigError
from ..core.measurements import Reading, is_period_key
from ..core.reading_ranges import (
    COUNT_KEYS,
    LENGTH_UNITS,
    RADIUS_RANGE,
    READING_RANGES,
    TRAIL_RANGE,
    PlausibleRange,
    plausible_range,
    reading_unit,
)
from ..core.suggest import did_you_mean
from ..core.units import radians
from ..pipeline.readings import (
    REFINED_STATIC_KEYS,
    STATIC_KEYS,
    ImpossibleReadingError,
    ReadingEntry,
    ReadingEntryError,
    UnknownReadingKeyError,
    check_entry,
    is_static_key,
)

__all__ = [
    "COUNT_KEYS",
    "ImpossibleValueError",
    "NotANumberError",
    "NotInPlanError",
    "PlausibleRange",
    "ReadingInputError",
    "SigmaError",
    "UnknownKeyError",
    "parse_reading",
    "plausibility",
    "plausible_range",
    "reading_unit",
]


class ReadingInputError(BikeRigError):
    """A typed reading that cannot be used; the message is one line: where, the key, why.

    Args:
        key: The key as typed.
        reason: Why it cannot be used.
        where: Where it was typed (e.g. ``"console"``, ``"stdin:12"``).
    """

    def __init__(self, key: str, reason: str, where: str = "reading"):
        """Keep the key, reason and place; the message is ``<where>: key '<key>': <reason>``."""
        self.key = key
        self.reason = reason
        self.where = where
        super().__init__(f"{where}: key '{key}': {reason}")


class UnknownKeyError(ReadingInputError):
    """Not a static reading's key (a typo, or a pendulum period, which trials provide)."""


class NotInPlanError(ReadingInputError):
    """A static key, but not one of this session's plan (e.g. a fourth orientation on a 3-orientation rig)."""


class NotANumberError(ReadingInputError):
    """The value or σ is not a finite number."""


class SigmaError(ReadingInputError):
    """σ is missing, negative, or 0 for a measured value (or not 0 for an exact count)."""


class ImpossibleValueError(ReadingInputError):
    """The value is physically impossible for its key (a negative mass, a head-tube angle over 90°)."""


# ----------------------------------------------------------------------------------------------
# Parsing and hard checks
# ----------------------------------------------------------------------------------------------


def _number(text: str | float, key: str, what: str, where: str) -> float:
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        x = float(text)
    else:
        try:
            x = float(str(text).strip())
        except ValueError:
            raise NotANumberError(key, f"{what} {str(text).strip()!r} is not a number", where) from None
    if not math.isfinite(x):
        raise NotANumberError(key, f"{what} must be a finite number, got {text!r}", where)
    return x


def _sigma(key: str, sigma_text: str | float | None, default_sigma: float | None, where: str) -> float:
    if sigma_text is None or (isinstance(sigma_text, str) and not sigma_text.strip()):
        if key in COUNT_KEYS:
            return 0.0
        if default_sigma is None:
            raise SigmaError(key, f"σ missing: give the reading's σ in {reading_unit(key)}", where)
        return float(default_sigma)
    sigma = _number(sigma_text, key, "σ", where)
    if sigma < 0:
        raise SigmaError(key, f"σ must be >= 0, got {sigma:g}", where)
    if key in COUNT_KEYS and sigma != 0:
        raise SigmaError(key, f"a number of rotations is an exact count: σ is 0, got {sigma:g}", where)
    if key not in COUNT_KEYS and sigma == 0:
        raise SigmaError(
            key,
            f"σ 0 would make the reading exact and drop it from every uncertainty; give the instrument's "
            f"σ in {reading_unit(key)}",
            where,
        )
    return sigma


def parse_reading(
    key: str,
    value_text: str | float,
    sigma_text: str | float | None = None,
    *,
    allowed: Collection[str] | None = None,
    default_sigma: float | None = None,
    where: str = "reading",
    stamp_ns: int = 0,
    note: str = "",
) -> ReadingEntry:
    """Parse and check one typed reading.

    The value must be finite and physically possible (the rule a measurement file meets:
    :func:`bike_rig.pipeline.readings.check_entry`), σ finite and ≥ 0. σ = 0 is refused for a
    measured value (it would drop out of every uncertainty: give the instrument's σ); the
    counts ``nR``/``nF`` are whole numbers with σ 0 (which may be left out).

    Args:
        key: The flat key, e.g. ``"gamma"``, ``"mF"``, ``"alphaB2"``.
        value_text: The value as typed, in the key's unit (:func:`reading_unit`).
        sigma_text: Its σ as typed, same unit; None or blank: ``default_sigma`` (0 for a count).
        allowed: The static keys of this session's plan; None accepts any static key.
        default_sigma: σ to use when none is typed (e.g. the rig's nominal σ of the reading);
            None makes a missing σ an error.
        where: Where it was typed, for the message (``"console"``, ``"stdin:12"``).
        stamp_ns: The entry's wall time, ns since the epoch.
        note: Free text kept with the entry (e.g. ``"correction"``).

    Returns:
        The entry, ready for :meth:`bike_rig.session.state.OperatorSession.on_reading`.

    Raises:
        UnknownKeyError: Not a static reading's key (or a period key).
        NotInPlanError: A static key outside ``allowed``.
        NotANumberError: The value or σ is not a finite number.
        SigmaError: σ missing, negative, 0 for a measured value, or not 0 for a count.
        ImpossibleValueError: The value is impossible for the key (a measurement file would
            refuse it too).
    """
    key = key.strip()
    if is_period_key(key) or not is_static_key(key):
        entry = ReadingEntry(key, math.nan, math.nan)
        try:
            check_entry(entry)
        except UnknownReadingKeyError as exc:
            hint = did_you_mean(key, allowed if allowed is not None else STATIC_KEYS + REFINED_STATIC_KEYS)
            raise UnknownKeyError(key, f"unknown key '{key}'{hint}" if hint else exc.reason, where) from None
    if allowed is not None and key not in allowed:
        hint = did_you_mean(key, allowed) or f" ({', '.join(allowed)})"
        raise NotInPlanError(key, f"not a reading of this session's plan{hint}", where)
    value = _number(value_text, key, "value", where)
    sigma = _sigma(key, sigma_text, default_sigma, where)
    entry = ReadingEntry(key, value, sigma, stamp_ns, note)
    try:
        check_entry(entry)
    except ImpossibleReadingError as exc:
        raise ImpossibleValueError(key, exc.reason, where) from None
    except ReadingEntryError as exc:  # not reached: key, finiteness and σ are checked above
        raise ReadingInputError(key, exc.reason, where) from None
    return entry


# ----------------------------------------------------------------------------------------------
# Plausibility
# ----------------------------------------------------------------------------------------------

#: The session's readings by key: plain values, or records with a ``value``.
Known = Mapping[str, float | Reading | ReadingEntry]


def _value_of(x: float | Reading | ReadingEntry) -> float:
    return float(x.value) if isinstance(x, (Reading, ReadingEntry)) else float(x)


def _unit_mistake(value: float, rng: PlausibleRange, unit: str) -> str:
    """``"looks like millimetres (= 1.08 m)"`` when wrong units explain the value (all of them), else ""."""
    fits = [f"{name} (= {value * factor:.4g} {unit})" for name, factor in rng.units if rng.holds(value * factor)]
    return f"looks like {' or '.join(fits)}" if fits else ""


def _angle_mistake(key: str, value: float) -> str:
    if key == "gamma":
        if 0 < value <= math.pi / 2 and READING_RANGES["gamma"].holds(math.degrees(value)):
            return f"looks like radians ({math.degrees(value):.4g}°); the head-tube angle is entered in degrees"
        if READING_RANGES["gamma"].holds(90.0 - value):
            return (
                f"looks like the steer-axis tilt from the vertical; the head-tube angle from the horizontal "
                f"is 90 - {value:g} = {90.0 - value:g}°"
            )
    if key.startswith("alpha"):
        return f"add or subtract 360 ({value % 360.0:g}°): the level reads 0 to 360°"
    return ""


def _range_warning(key: str, value: float, known: Mapping[str, float]) -> str:
    rng = plausible_range(key)
    if rng is None or rng.holds(value):
        return ""
    if key in ("dR", "dF", "nR", "nF") and _radius(known, key[1]) is not None:
        return ""  # judged by the wheel radius they give together (see _wheel_radius)
    unit = reading_unit(key)
    likely = _unit_mistake(value, rng, unit) or _angle_mistake(key, value)
    span = f"{rng.low:g} to {rng.high:g} {unit}"
    text = f"{key} = {value:g}: outside the plausible {rng.what} ({span})"
    return f"{text}; {likely}" if likely else text


def _sigma_warning(key: str, value: float, sigma: float) -> str:
    signed = key.startswith(("alpha", "a")) or key == "f"  # near-zero values are normal there
    if signed or not sigma > abs(value):
        return ""
    return f"{key} = {value:g} ± {sigma:g}: σ is larger than the value; is σ in another unit than the value?"


def _radius(known: Mapping[str, float], p: str) -> float | None:
    d, n = known.get(f"d{p}"), known.get(f"n{p}")
    if d is None or n is None or not n > 0:
        return None
    return float(geometry.wheel_radius(d, n))


def _plausible_radius(known: Mapping[str, float], p: str) -> float | None:
    """The wheel radius when it is known and plausible (an implausible one has its own warning)."""
    r = _radius(known, p)
    return r if r is not None and RADIUS_RANGE[0] <= r <= RADIUS_RANGE[1] else None


def _radius_mistake(key: str, p: str, d: float, n: float, r: float) -> str:
    if key == f"n{p}":
        return f"is the number of rotations n{p} = {n:g} right?"
    for name, factor in LENGTH_UNITS[:2]:
        if RADIUS_RANGE[0] <= r * factor <= RADIUS_RANGE[1]:
            return f"the distance d{p} = {d:g} looks like {name}"
    if RADIUS_RANGE[0] <= r * n <= RADIUS_RANGE[1]:
        return f"d{p} = {d:g} m looks like the distance of one rotation, not of n{p} = {n:g}"
    return f"is d{p} in metres, and n{p} = {n:g} the number of rotations over it?"


def _wheel_radius(key: str, value: float, known: Mapping[str, float]) -> Iterator[str]:
    if key not in ("dR", "dF", "nR", "nF"):
        return
    p = key[1]
    r = _radius(known, p)
    if r is None or RADIUS_RANGE[0] <= r <= RADIUS_RANGE[1]:
        return
    likely = _radius_mistake(key, p, known[f"d{p}"], known[f"n{p}"], r)
    yield (
        f"{key} = {value:g}: the wheel radius d{p} / (2π n{p}) = {r:.4g} m is no wheel's "
        f"({RADIUS_RANGE[0]:g} to {RADIUS_RANGE[1]:g} m); {likely}"
    )


def _pendulum_arm(key: str, value: float, known: Mapping[str, float]) -> Iterator[str]:
    if key not in ("lR", "lF", "dR", "dF", "nR", "nF"):
        return
    p = key[1]
    r, arm = _plausible_radius(known, p), known.get(f"l{p}")
    if r is None or arm is None or arm <= r:
        return
    yield (
        f"{key} = {value:g}: the pendulum arm l{p} = {arm:g} m is longer than the wheel radius "
        f"d{p} / (2π n{p}) = {r:.4g} m; the arm is from the rim's contact to the wheel centre"
    )


def _trail(key: str, value: float, known: Mapping[str, float]) -> Iterator[str]:
    if key not in ("gamma", "f", "dF", "nF"):
        return
    rF = _plausible_radius(known, "F")
    if rF is None or "gamma" not in known or "f" not in known:
        return
    lam = geometry.steer_axis_tilt(radians(known["gamma"]))
    c = float(geometry.trail(rF, lam, known["f"]))
    if TRAIL_RANGE[0] <= c <= TRAIL_RANGE[1]:
        return
    f, gamma = known["f"], known["gamma"]
    if not READING_RANGES["f"].holds(f):
        likely = f"the fork offset f = {f:g} is not in metres" + (
            f": it {mistake}" if (mistake := _unit_mistake(f, READING_RANGES["f"], "m")) else ""
        )
    elif not READING_RANGES["gamma"].holds(gamma):
        likely = f"is the head-tube angle gamma = {gamma:g} in degrees from the horizontal?"
    else:
        likely = "check the fork offset f and the head-tube angle gamma"
    yield (
        f"{key} = {value:g}: the trail (Eq 8) comes out as c = {c:.4g} m, no bicycle's "
        f"({TRAIL_RANGE[0]:g} to {TRAIL_RANGE[1]:g} m); {likely}"
    )


def _wheelbase(key: str, value: float, known: Mapping[str, float]) -> Iterator[str]:
    if key not in ("w", "dR", "nR", "dF", "nF"):
        return
    rR, rF, w = _plausible_radius(known, "R"), _plausible_radius(known, "F"), known.get("w")
    if rR is None or rF is None or w is None or w >= rR + rF:
        return
    yield f"{key} = {value:g}: the wheelbase w = {w:g} m is shorter than the two wheel radii together ({rR + rF:.4g} m)"


_CROSS_CHECKS: tuple[Callable[[str, float, Mapping[str, float]], Iterator[str]], ...] = (
    _wheel_radius,
    _pendulum_arm,
    _trail,
    _wheelbase,
)


def plausibility(key: str, value: float, sigma: float, readings_so_far: Known) -> list[str]:
    """Warnings about a possible but probably mistaken reading.

    A head-tube angle that looks like radians or the steer-axis tilt, a length in mm, cm or
    inches, a mass in grams or pounds or out of range for its part, σ above the value, a hanging
    angle outside 0–360°, a wheel radius no wheel has, a pendulum arm longer than the radius, a
    trail (Eq 8) in metres. Ranges: :mod:`bike_rig.core.reading_ranges` (no reading of the
    paper's or the shared data's bicycles warns).

    Args:
        key: The static key (checked by :func:`parse_reading` before).
        value: The value, in the key's unit.
        sigma: Its σ, same unit.
        readings_so_far: The session's other readings by key (values, or
            :class:`~bike_rig.core.measurements.Reading` / ``ReadingEntry``); an earlier reading
            of ``key`` itself is replaced by this one.

    Returns:
        One line per warning, each naming the key, the value and the likely mistake; empty
        when nothing looks wrong.
    """
    known = {k: _value_of(v) for k, v in readings_so_far.items()}
    known[key] = float(value)
    out = [w for w in (_range_warning(key, value, known), _sigma_warning(key, value, sigma)) if w]
    for check in _CROSS_CHECKS:
        out.extend(check(key, value, known))
    return out
