"""Critical speeds of the Whipple model from the Routh–Hurwitz structure of its quartic.

:func:`critical_speeds` gives the weave and capsize speeds (m/s) and every crossing of the
imaginary axis (:class:`Crossing`), :func:`stable_speed_range` the speed intervals (m/s) where
every eigenvalue has ``Re s < 0``; both in closed form (roots of ``a0(v)`` and of the Hurwitz
determinant, each a quadratic in ``v²``) and then polished by Newton. The same formulas
(:func:`hurwitz_determinant`, :func:`hurwitz_quadratic`, :func:`pair_crossing_rate`) serve the
vectorised Monte Carlo in :mod:`bike_rig.core.uncertainty.speed_mc`.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .matrices import WhippleMatrices, characteristic_polynomial, check_one_bicycle

__all__ = [
    "CriticalSpeeds",
    "Crossing",
    "critical_speeds",
    "hurwitz_determinant",
    "hurwitz_quadratic",
    "pair_crossing_rate",
    "stable_speed_range",
]


# --------------------------------------------------------------------------------------------
# Critical speeds (Routh–Hurwitz structure)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Crossing:
    """A speed at which eigenvalues cross the imaginary axis.

    Attributes:
        speed: The speed (m/s).
        kind: ``"real"`` (a real root through ``s = 0``, where ``a0(v) = 0``) or
            ``"oscillatory"`` (a complex pair through ``±iω``, where the Hurwitz determinant
            vanishes with ``ω² = a1/a3 > 0``).
        frequency: ``ω`` (rad/s); 0 for a real crossing.
        rate: ``d Re(s)/dv`` at the crossing (1/m): positive if the root moves into the right
            half plane as speed increases (destabilising), negative if it leaves it.
    """

    speed: float
    kind: str
    frequency: float
    rate: float


@dataclass(frozen=True)
class CriticalSpeeds:
    """Weave and capsize speeds of one bicycle.

    Attributes:
        weave: Lowest speed (m/s) where a complex pair crosses from ``Re s > 0`` to
            ``Re s < 0``, or ``None`` if there is none in ``(0, v_max]``.
        capsize: Lowest speed (m/s) where a real root crosses from negative to positive, or
            ``None``.
        crossings: Every crossing found in ``(0, v_max]``, by increasing speed.
    """

    weave: float | None
    capsize: float | None
    crossings: tuple[Crossing, ...]


def _poly_rows(matrices: WhippleMatrices, g: float) -> list[list[float]]:
    """``rows[k][j]``: coefficient of ``s^k v^j`` as Python floats (one real bicycle)."""
    check_one_bicycle(matrices)
    coef = np.asarray(characteristic_polynomial(matrices, float(g)).coefficients, dtype=float)
    lead = float(coef[4, 0])
    # Normalise to a4 = 1 (> 0) so that the Hurwitz sign conditions read "all positive".
    return [[float(x) / lead for x in row] for row in coef]


def _eval_a(rows: list[list[float]], v: float) -> tuple[list[float], list[float]]:
    """``a_k(v)`` and ``d a_k / dv`` for ``k = 0..4``."""
    vals, ders = [], []
    for row in rows:
        vals.append(sum(c * v**j for j, c in enumerate(row)))
        ders.append(sum(j * c * v ** (j - 1) for j, c in enumerate(row) if j))
    return vals, ders


def hurwitz_determinant(a: Sequence[Any], da: Sequence[Any]) -> tuple[Any, Any]:
    """``H = a3 a2 a1 - a4 a1² - a0 a3²`` and ``dH/dv`` from the ``a_k`` and their derivatives.

    An oscillatory pair of the quartic ``a4 s⁴ + … + a0`` crosses the imaginary axis where
    ``H = 0`` (Routh–Hurwitz). Element-wise: the ``a_k`` may be floats or arrays.
    """
    a0, a1, a2, a3, a4 = a
    d0, d1, d2, d3, d4 = da
    h = a3 * a2 * a1 - a4 * a1 * a1 - a0 * a3 * a3
    dh = (
        d3 * a2 * a1
        + a3 * d2 * a1
        + a3 * a2 * d1
        - d4 * a1 * a1
        - 2.0 * a4 * a1 * d1
        - d0 * a3 * a3
        - 2.0 * a0 * a3 * d3
    )
    return h, dh


def _quadratic_real_roots(c2: float, c1: float, c0: float) -> list[float]:
    """Real roots of ``c2 x² + c1 x + c0`` (cancellation-free; degree drops when ``c2 = 0``)."""
    if c2 == 0.0:
        return [-c0 / c1] if c1 != 0.0 else []
    disc = c1 * c1 - 4.0 * c2 * c0
    if disc < 0.0:
        return []
    big = -0.5 * (c1 + math.copysign(math.sqrt(disc), c1))
    return [big / c2, c0 / big] if big != 0.0 else [0.0]


def _newton(func: Any, v: float) -> float:
    """Polish a simple root ``v`` of ``func(v) -> (f, df)`` (stops at ``|Δv| ≤ 1e-15 v``)."""
    for _ in range(20):
        f, df = func(v)
        if df == 0.0 or not math.isfinite(f / df):
            break
        step = f / df
        v -= step
        if abs(step) <= 1e-15 * abs(v):
            break
    return v


def hurwitz_quadratic(c: Any) -> tuple[Any, Any, Any]:
    """``(q2, q1, q0)``: the Hurwitz determinant is ``H(v) = v² (q2 u² + q1 u + q0)``, ``u = v²``.

    Args:
        c: Characteristic-polynomial coefficients indexed ``c[k][j]`` (``s^k v^j``), as nested
            lists of floats or as an array whose first two axes are ``k, j`` (any batch axes
            after them), see :func:`_candidates`.
    """
    e00, e02, e04 = c[0][0], c[0][2], c[0][4]
    e10, e12, e20, e22 = c[1][1], c[1][3], c[2][0], c[2][2]
    e3, m = c[3][1], c[4][0]
    q2 = e3 * e22 * e12 - m * e12 * e12 - e3 * e3 * e04
    q1 = e3 * (e20 * e12 + e22 * e10) - 2.0 * m * e10 * e12 - e3 * e3 * e02
    q0 = e3 * e20 * e10 - m * e10 * e10 - e3 * e3 * e00
    return q2, q1, q0


def pair_crossing_rate(a: Sequence[Any], da: Sequence[Any], omega: Any) -> Any:
    """``d Re s/dv`` (1/m) of a pair ``s = ±iω`` on the imaginary axis.

    It is ``Re(-(∂p/∂v)/(∂p/∂s))`` at ``s = iω`` (implicit function theorem on
    ``p(s, v) = Σ a_k(v) s^k``); 1/m.

    Args:
        a: ``a_k(v)``, k = 0..4 (floats or arrays).
        da: ``d a_k/dv``.
        omega: ``ω`` (rad/s).
    """
    s = 1j * omega
    dp_ds = sum(k * a[k] * s ** (k - 1) for k in range(1, 5))
    dp_dv = sum(da[k] * s**k for k in range(5))
    return (-dp_dv / dp_ds).real


def _candidates(rows: list[list[float]]) -> tuple[list[float], list[float]]:
    """Closed-form positive roots of ``a0(v)`` and of the Hurwitz determinant ``H(v)``.

    With ``u = v²``: ``a4 = m``, ``a3 = e3 v``, ``a2 = e20 + e22 u``, ``a1 = v (e10 + e12 u)``
    and ``a0 = e00 + e02 u + e04 u²``; so ``a0`` is a quadratic in ``u`` and

    ``H = a3 a2 a1 - a4 a1² - a0 a3² = u [e3 (e20 + e22 u)(e10 + e12 u) - m (e10 + e12 u)²
    - e3² (e00 + e02 u + e04 u²)]``,

    ``v²`` times a quadratic ``q2 u² + q1 u + q0`` in ``u``.
    """
    (e00, _, e02, _, e04) = rows[0]
    q2, q1, q0 = hurwitz_quadratic(rows)
    real = [math.sqrt(u) for u in _quadratic_real_roots(e04, e02, e00) if u > 0.0]
    osc = [math.sqrt(u) for u in _quadratic_real_roots(q2, q1, q0) if u > 0.0]
    return real, osc


def _real_crossing(rows: list[list[float]], v0: float) -> Crossing | None:
    """Polish a root of ``a0`` and return its crossing (``ds/dv = -a0'(v)/a1(v)`` at s = 0)."""

    def a0(v: float) -> tuple[float, float]:
        a, da = _eval_a(rows, v)
        return a[0], da[0]

    v = _newton(a0, v0)
    a, da = _eval_a(rows, v)
    if a[1] == 0.0 or da[0] == 0.0:
        return None  # a double root at s = 0 or a touching zero: no crossing
    return Crossing(speed=v, kind="real", frequency=0.0, rate=-da[0] / a[1])


def _oscillatory_crossing(rows: list[list[float]], v0: float) -> Crossing | None:
    """Polish a root of ``H`` and return the crossing of the pair ``±iω``, ``ω² = a1/a3``.

    The rate is ``Re(-(∂p/∂v)/(∂p/∂s))`` at ``s = iω`` (implicit function theorem on the
    characteristic polynomial ``p(s, v)``).
    """
    v = _newton(lambda x: hurwitz_determinant(*_eval_a(rows, x)), v0)
    a, da = _eval_a(rows, v)
    if a[3] == 0.0 or a[1] / a[3] <= 0.0:
        return None  # H = 0 without a purely imaginary pair (e.g. a pair of opposite reals)
    omega = math.sqrt(a[1] / a[3])
    try:
        rate = float(pair_crossing_rate(a, da, omega))
    except ZeroDivisionError:
        return None  # ∂p/∂s = 0: a double root on the axis
    return Crossing(speed=v, kind="oscillatory", frequency=omega, rate=rate)


def _all_crossings(rows: list[list[float]], v_max: float) -> list[Crossing]:
    """All polished crossings in ``(0, v_max]``, by increasing speed."""
    real, osc = _candidates(rows)
    found = [_real_crossing(rows, v) for v in real] + [_oscillatory_crossing(rows, v) for v in osc]
    return sorted((c for c in found if c is not None and 0.0 < c.speed <= v_max), key=lambda c: c.speed)


def critical_speeds(matrices: WhippleMatrices, g: float, v_max: float = math.inf) -> CriticalSpeeds:
    """Weave and capsize speeds (m/s), from closed-form candidates polished by Newton.

    For ``p(s) = a4 s⁴ + a3 s³ + a2 s² + a1 s + a0``, a real root crosses ``s = 0`` where
    ``a0(v) = det(g K0 + v² K2) = 0`` (a quadratic in ``v²``), and a complex pair crosses the
    imaginary axis at ``±iω`` where the Hurwitz determinant ``a3 a2 a1 - a4 a1² - a0 a3²``
    vanishes with ``ω² = a1/a3 > 0``; that determinant is ``v²`` times a quadratic in ``v²``
    (see :func:`_candidates`). Each candidate is polished by Newton on the unexpanded
    function to machine precision, and its direction is the sign of ``d Re(s)/dv``.

    Args:
        matrices: Canonical matrices of one bicycle.
        g: Gravity (m/s²).
        v_max: Only crossings at speeds in ``(0, v_max]`` count (m/s).

    Returns:
        ``weave``: lowest stabilising oscillatory crossing; ``capsize``: lowest destabilising
        real crossing; either ``None`` when absent (e.g. ``capsize`` when ``a0(v)`` has no
        positive root).

    Raises:
        ModelError: Matrices not of one real bicycle, or singular ``M``.
    """
    crossings = _all_crossings(_poly_rows(matrices, g), v_max)
    weave = next((c.speed for c in crossings if c.kind == "oscillatory" and c.rate < 0.0), None)
    capsize = next((c.speed for c in crossings if c.kind == "real" and c.rate > 0.0), None)
    return CriticalSpeeds(weave=weave, capsize=capsize, crossings=tuple(crossings))


def _is_stable(rows: list[list[float]], v: float) -> bool:
    """Liénard–Chipart test at one speed: all ``a_k > 0`` (with ``a4 = 1``) and ``H > 0``."""
    a, da = _eval_a(rows, v)
    return all(x > 0.0 for x in a) and hurwitz_determinant(a, da)[0] > 0.0


def stable_speed_range(matrices: WhippleMatrices, g: float, v_max: float = math.inf) -> tuple[tuple[float, float], ...]:
    """Speed intervals within ``(0, v_max]`` where every eigenvalue has ``Re s < 0``.

    Stability can only change where an eigenvalue crosses the imaginary axis, i.e. at a root
    of ``a0`` or of the Hurwitz determinant; every root of either (also those without a
    crossing) splits ``(0, v_max)``, and the Liénard–Chipart conditions are tested in the
    middle of each piece (at ``2 v + 1`` beyond the last one when ``v_max`` is infinite).

    Args:
        matrices: Canonical matrices of one bicycle.
        g: Gravity (m/s²).
        v_max: Upper end of the speeds considered (m/s).

    Returns:
        Disjoint ``(low, high)`` intervals (m/s), increasing; for the benchmark bicycle one
        interval ``(weave, capsize)``; ``high`` may be ``inf``.
    """
    rows = _poly_rows(matrices, g)
    real, osc = _candidates(rows)
    split = [_newton(lambda x: (_eval_a(rows, x)[0][0], _eval_a(rows, x)[1][0]), v) for v in real]
    split += [_newton(lambda x: hurwitz_determinant(*_eval_a(rows, x)), v) for v in osc]
    edges = [0.0, *sorted(v for v in split if 0.0 < v < v_max), v_max]
    out: list[tuple[float, float]] = []
    for lo, hi in itertools.pairwise(edges):
        probe = 0.5 * (lo + hi) if math.isfinite(hi) else 2.0 * lo + 1.0
        if hi > lo and _is_stable(rows, probe):
            if out and out[-1][1] == lo:
                out[-1] = (out[-1][0], hi)
            else:
                out.append((lo, hi))
    return tuple(out)
