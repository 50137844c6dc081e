"""Linear state feedback on the steer torque: the feedback file and its gains at any speed.

A controller adds ``T_δ = −(kφ φ + kδ δ + kφ̇ φ̇ + kδ̇ δ̇)`` (N m) to the Whipple model's steer
torque (``x = [φ, δ, φ̇, δ̇]``, ``u = [T_φ, T_δ]``): the closed loop is ``ẋ = (A − B K) x``,
``K = [[0, 0, 0, 0], [kφ, kδ, kφ̇, kδ̇]]``. The file (``format: bike_rig-feedback/1``, in
``docs/formats.md``) gives each gain (N m/rad, N m s/rad) as a number or a table over speed
(m/s; linear inside, held outside), optionally with σ (:meth:`Feedback.uncertain_knots`), and
optionally the controller's rate ``rate_hz`` (Hz; a digital controller that samples the state and
holds the torque one period; absent: continuous). :func:`resolve_feedback` is the one place a
feedback choice becomes a :class:`Feedback`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import InputFileError, short_repr
from .io_yaml import load_yaml_document
from .measurements import MAX_MAGNITUDE

__all__ = [
    "FEEDBACK_FORMAT",
    "GAIN_KEYS",
    "GAIN_UNITS",
    "NO_FEEDBACK",
    "RATE_KEY",
    "Feedback",
    "FeedbackError",
    "GainSchedule",
    "feedback_key",
    "load_feedback",
    "resolve_feedback",
]

FloatArray = NDArray[np.float64]

#: The ``format`` of a feedback file.
FEEDBACK_FORMAT = "bike_rig-feedback/1"
#: The gain keys in state order ``[φ, δ, φ̇, δ̇]`` (N m/rad, N m/rad, N m s/rad, N m s/rad).
GAIN_KEYS: tuple[str, str, str, str] = ("k_phi", "k_delta", "k_phidot", "k_deltadot")
#: The unit of each gain of :data:`GAIN_KEYS`.
GAIN_UNITS: tuple[str, str, str, str] = ("N m/rad", "N m/rad", "N m s/rad", "N m s/rad")
#: The record name of "no feedback".
NO_FEEDBACK = ""
#: The key of a digital controller's sample rate (Hz).
RATE_KEY = "rate_hz"
_OTHER_KEYS = ("format", "name", RATE_KEY)


class FeedbackError(InputFileError):
    """A feedback file is missing, unreadable, or has an unknown key or a bad gain."""


@dataclass(frozen=True)
class GainSchedule:
    """One gain over speed: a constant, or a piecewise-linear table held constant outside.

    Attributes:
        speeds: The table's speeds (m/s), strictly increasing; empty for a constant gain.
        values: The gain at each speed (one value for a constant), N m/rad or N m s/rad.
        sigmas: σ of each value (same unit), independent; empty when the gain is exact.
    """

    speeds: tuple[float, ...]
    values: tuple[float, ...]
    sigmas: tuple[float, ...] = ()

    @classmethod
    def constant(cls, value: float) -> GainSchedule:
        """A gain that does not depend on the speed."""
        return cls((), (float(value),))

    def at(self, v: ArrayLike) -> FloatArray:
        """The gain at the speeds ``v`` (m/s): linear between table speeds, constant outside."""
        speed = np.asarray(v, dtype=float)
        if not self.speeds:
            return np.full(speed.shape, self.values[0])
        return np.asarray(np.interp(speed, self.speeds, self.values), dtype=float)

    def slope(self, v: ArrayLike) -> FloatArray:
        """``d gain/dv`` at the speeds ``v`` (m/s): the slope of the table piece holding ``v``.

        Zero outside the table and for a constant; at a table speed, the slope of the piece
        above it (the gains have a kink there).
        """
        speed = np.asarray(v, dtype=float)
        if len(self.speeds) < 2:
            return np.zeros(speed.shape)
        knots, values = np.asarray(self.speeds), np.asarray(self.values)
        rates = np.concatenate([[0.0], np.diff(values) / np.diff(knots), [0.0]])
        return np.asarray(rates[np.searchsorted(knots, speed, side="right")], dtype=float)

    def weight(self, v: ArrayLike, j: int) -> FloatArray:
        """``∂ gain(v) / ∂ values[j]`` at the speeds ``v`` (m/s): the interpolation weight (-)."""
        speed = np.asarray(v, dtype=float)
        if not self.speeds:
            return np.ones(speed.shape)
        unit = np.zeros(len(self.values))
        unit[j] = 1.0
        return np.asarray(np.interp(speed, self.speeds, unit), dtype=float)

    def describe(self) -> str:
        """The gain for people: ``2.5 ± 0.1`` or ``-50 at 0 m/s, 0 at 5 m/s (linear between, held outside)``."""

        def value(j: int) -> str:
            sigma = self.sigmas[j] if self.sigmas else 0.0
            return f"{self.values[j]:g}" + (f" ± {sigma:g}" if sigma > 0.0 else "")

        if not self.speeds:
            return value(0)
        points = ", ".join(f"{value(j)} at {v:g} m/s" for j, v in enumerate(self.speeds))
        return points + " (linear between, held outside)"

    @property
    def is_zero(self) -> bool:
        """Whether the gain is zero at every speed."""
        return all(x == 0.0 for x in self.values)


_ZERO = GainSchedule.constant(0.0)


@dataclass(frozen=True)
class Feedback:
    """Steer-torque state feedback ``T_δ = −(kφ φ + kδ δ + kφ̇ φ̇ + kδ̇ δ̇)``.

    Attributes:
        name: A label for outputs.
        k_phi: Roll-angle gain, N m/rad.
        k_delta: Steer-angle gain, N m/rad.
        k_phidot: Roll-rate gain, N m s/rad.
        k_deltadot: Steer-rate gain, N m s/rad.
        source: The file it was read from ("" when built in code).
        rate_hz: A digital controller's sample rate (Hz): it samples the state and holds the
            torque for ``1/rate_hz`` s. None: a continuous controller.
    """

    name: str
    k_phi: GainSchedule = _ZERO
    k_delta: GainSchedule = _ZERO
    k_phidot: GainSchedule = _ZERO
    k_deltadot: GainSchedule = _ZERO
    source: str = ""
    rate_hz: float | None = None

    @property
    def period(self) -> float | None:
        """The controller's period ``1/rate_hz`` (s), or None for a continuous controller."""
        return None if self.rate_hz is None else 1.0 / self.rate_hz

    @property
    def schedules(self) -> tuple[GainSchedule, GainSchedule, GainSchedule, GainSchedule]:
        """The four gains in state order (:data:`GAIN_KEYS`)."""
        return (self.k_phi, self.k_delta, self.k_phidot, self.k_deltadot)

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Every table speed of every gain (m/s), sorted: the gains are linear between them."""
        return tuple(sorted({v for s in self.schedules for v in s.speeds}))

    def gains(self, v: ArrayLike) -> FloatArray:
        """``[kφ, kδ, kφ̇, kδ̇]`` at the speeds ``v`` (m/s): shape ``shape(v) + (4,)``, SI."""
        return np.stack([s.at(v) for s in self.schedules], axis=-1)

    def slopes(self, v: ArrayLike) -> FloatArray:
        """``d/dv [kφ, kδ, kφ̇, kδ̇]`` at the speeds ``v`` (:meth:`GainSchedule.slope`), shape ``shape(v) + (4,)``."""
        return np.stack([s.slope(v) for s in self.schedules], axis=-1)

    def uncertain_knots(self) -> tuple[tuple[int, int, float, str], ...]:
        """Every gain value given with σ > 0: ``(gain index, value index, σ, label)``.

        The gain index is in :data:`GAIN_KEYS` order; the label names the value as the file
        does (``k_phi`` or ``k_phidot.values[1]``).
        """
        out = []
        for i, (key, s) in enumerate(zip(GAIN_KEYS, self.schedules, strict=True)):
            for j, sigma in enumerate(s.sigmas):
                if sigma > 0.0:
                    out.append((i, j, float(sigma), key if not s.speeds else f"{key}.values[{j}]"))
        return tuple(out)

    def knot_jacobian(self, v: ArrayLike) -> FloatArray:
        """``∂[kφ, kδ, kφ̇, kδ̇](v) / ∂`` each uncertain value: shape ``shape(v) + (n, 4)``.

        ``n`` is the number of :meth:`uncertain_knots`.
        """
        speed = np.asarray(v, dtype=float)
        knots = self.uncertain_knots()
        out = np.zeros(speed.shape + (len(knots), 4))
        for n, (i, j, _, _) in enumerate(knots):
            out[..., n, i] = self.schedules[i].weight(speed, j)
        return out

    def gains_at(self, v: ArrayLike) -> FloatArray:
        """The steer-torque gain row ``K`` (the input's steer row), shape ``shape(v) + (1, 4)``.

        The closed loop is ``A − B[:, 1:] K`` (``B[:, 1]`` is the steer-torque column).
        """
        return self.gains(v)[..., None, :]


def _error(path: str, lines: Mapping[tuple[object, ...], int], where: tuple[object, ...], reason: str) -> FeedbackError:
    """A :class:`FeedbackError` at the key ``where`` (its line, else its parent's)."""
    line = lines.get(where, lines.get(where[:1]))
    key = ".".join(str(x) if not isinstance(x, int) else f"[{x}]" for x in where).replace(".[", "[") or None
    return FeedbackError(path, reason, key=key, line=line)


def _number(x: Any) -> float | None:
    """``x`` as a finite float within :data:`MAX_MAGNITUDE`, or None when it is not one."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return None
    if abs(x) > MAX_MAGNITUDE:
        return None
    value = float(x)
    return value if math.isfinite(value) else None


def _numbers(path: str, lines: Mapping[tuple[object, ...], int], where: tuple[object, ...], items: Any) -> list[float]:
    """A non-empty list of finite numbers, or a :class:`FeedbackError` naming the bad item."""
    if not isinstance(items, list) or not items:
        raise _error(path, lines, where, f"expected a non-empty list of numbers, got {short_repr(items)}")
    out = []
    for i, x in enumerate(items):
        value = _number(x)
        if value is None:
            raise _error(path, lines, where + (i,), f"needs a finite number ({short_repr(x)} given)")
        out.append(value)
    return out


def _sigmas(path: str, lines: Mapping[tuple[object, ...], int], where: tuple[object, ...], items: Any) -> list[float]:
    """σ values: finite numbers ≥ 0."""
    out = _numbers(path, lines, where, items)
    for i, s in enumerate(out):
        if s < 0.0:
            raise _error(path, lines, where + (i,), f"a σ must be >= 0 ({s:g} given)")
    return out


def _constant(path: str, lines: Mapping[tuple[object, ...], int], key: str, spec: Any) -> GainSchedule:
    """A constant gain: a number, or ``[value, sigma]``."""
    where: tuple[object, ...] = (key,)
    if isinstance(spec, list) and len(spec) == 2:
        value, sigma = _number(spec[0]), _number(spec[1])
        if value is not None and sigma is not None:
            if sigma < 0.0:
                raise _error(path, lines, where, f"a σ must be >= 0 ({sigma:g} given)")
            return GainSchedule((), (value,), (sigma,))
    value = _number(spec)
    if value is None:
        reason = (
            f"a gain is a finite number, [value, sigma] or {{speeds: [...], values: [...]}} ({short_repr(spec)} given)"
        )
        raise _error(path, lines, where, reason)
    return GainSchedule.constant(value)


def _schedule(path: str, lines: Mapping[tuple[object, ...], int], key: str, spec: Any) -> GainSchedule:
    """One gain: a number, ``[value, sigma]``, or a table ``{speeds: [...], values: [...], sigmas: [...]}``."""
    where: tuple[object, ...] = (key,)
    if not isinstance(spec, Mapping):
        return _constant(path, lines, key, spec)
    unknown = sorted(str(k) for k in spec if k not in ("speeds", "values", "sigmas"))
    if unknown or "speeds" not in spec or "values" not in spec:
        extra = f"; unknown {', '.join(unknown)}" if unknown else ""
        reason = f"a gain table has the keys speeds (m/s) and values, and optionally sigmas{extra}"
        raise _error(path, lines, where, reason)
    speeds = _numbers(path, lines, where + ("speeds",), spec["speeds"])
    values = _numbers(path, lines, where + ("values",), spec["values"])
    if len(speeds) != len(values):
        reason = f"{len(values)} values for {len(speeds)} speeds: a table needs one value per speed"
        raise _error(path, lines, where + ("values",), reason)
    sigmas = _sigmas(path, lines, where + ("sigmas",), spec["sigmas"]) if "sigmas" in spec else []
    if sigmas and len(sigmas) != len(values):
        reason = f"{len(sigmas)} sigmas for {len(values)} values: one σ per value"
        raise _error(path, lines, where + ("sigmas",), reason)
    for i in range(1, len(speeds)):
        if not speeds[i] > speeds[i - 1]:
            reason = f"speeds must increase strictly ({speeds[i - 1]:g} then {speeds[i]:g} m/s)"
            raise _error(path, lines, where + ("speeds", i), reason)
    return GainSchedule(tuple(speeds), tuple(values), tuple(sigmas))


def _rate(path: str, lines: Mapping[tuple[object, ...], int], spec: Any) -> float:
    """The controller's rate (Hz): a finite number > 0."""
    value = _number(spec)
    if value is None or value <= 0.0:
        reason = (
            f"the controller's rate is a finite number > 0 Hz ({short_repr(spec)} given); "
            "leave it out for a continuous controller"
        )
        raise _error(path, lines, (RATE_KEY,), reason)
    return value


def load_feedback(path: str | Path) -> Feedback:
    """A feedback from a YAML file (``format: bike_rig-feedback/1``, see ``docs/formats.md``).

    Raises:
        FeedbackError: The file is missing, unreadable or not YAML, has the wrong format, an
            unknown key, a bad gain (not a finite number; a table with non-increasing speeds,
            a length mismatch or a non-finite entry) or a ``rate_hz`` that is not a finite
            number > 0, with the file, key and line.
    """
    spec = str(path)
    try:
        data, lines = load_yaml_document(spec)
    except InputFileError as exc:
        raise FeedbackError(exc.path, exc.reason, exc.key, exc.line) from None
    if not isinstance(data, dict):
        raise FeedbackError(spec, f"a feedback file is a mapping with format: {FEEDBACK_FORMAT} and gain keys")
    if data.get("format") != FEEDBACK_FORMAT:
        reason = f"expected format: {FEEDBACK_FORMAT}, got {short_repr(data.get('format'))}"
        raise _error(spec, lines, ("format",), reason)
    for k in data:
        if k not in GAIN_KEYS and k not in _OTHER_KEYS:
            allowed = ", ".join(GAIN_KEYS + _OTHER_KEYS)
            raise _error(spec, lines, (str(k),), f"unknown key (a feedback file has {allowed})")
    gains = {k: _schedule(spec, lines, k, data[k]) for k in GAIN_KEYS if k in data}
    rate = _rate(spec, lines, data[RATE_KEY]) if RATE_KEY in data else None
    name = data.get("name", Path(spec).stem)
    return Feedback(name=str(name), source=spec, rate_hz=rate, **gains)


def feedback_key(spec: str | Path | None) -> str:
    """The feedback choice's name in records: ``""`` (none) or the feedback file's path.

    Args:
        spec: ``None``, ``""`` or ``"none"`` (no feedback), or the path of a feedback file.
    """
    if spec is None or spec in (NO_FEEDBACK, "none"):
        return NO_FEEDBACK
    return str(spec)


def resolve_feedback(spec: str | Path | None) -> Feedback | None:
    """The feedback chosen by ``spec``: the one place a feedback choice becomes a :class:`Feedback`.

    Args:
        spec: ``None``, ``""`` or ``"none"`` (no feedback), or the path of a feedback file
            (:func:`load_feedback`) or a shipped one's name (``balance_assist``).

    Returns:
        The feedback, or ``None`` for none.

    Raises:
        FeedbackError: The file cannot be read or is not a valid feedback file.
    """
    from ..config.paths import resolve_shipped

    key = feedback_key(spec)
    return None if key == NO_FEEDBACK else load_feedback(resolve_shipped(str(key), "feedback"))
