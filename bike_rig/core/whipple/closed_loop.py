"""The Whipple model under linear steer-torque state feedback: ``ẋ = (A − B K) x``.

The feedback ``T_δ = −(kφ φ + kδ δ + kφ̇ φ̇ + kδ̇ δ̇)`` (gains over speed, :class:`SteerFeedback`)
adds ``[kφ + kφ̇ s, kδ + kδ̇ s]`` to the steer row of ``P(s) = M s² + v C1 s + g K0 + v² K2``:
``det P_cl = det P + (kδ + kδ̇ s) P_φφ − (kφ + kφ̇ s) P_φδ`` (:func:`steer_feedback_terms`), still
a quartic with ``a4 = det M``. With gains piecewise linear in v, each ``a_k(v)`` stays a
polynomial of the open loop's degree, so the critical speeds are exact polynomial roots found
piece by piece (:func:`closed_loop_critical_speeds`), no grid. Checked against
``numpy.linalg.eigvals(A − B K)`` in ``test/core/test_feedback.py``. SI; speeds m/s,
eigenvalues 1/s.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import ArrayLike, NDArray

from .matrices import WhippleMatrices, characteristic_polynomial, check_one_bicycle, state_space
from .stability import CriticalSpeeds, Crossing, _newton, hurwitz_determinant, pair_crossing_rate

__all__ = [
    "SteerFeedback",
    "closed_loop_coefficients",
    "closed_loop_critical_speeds",
    "closed_loop_rows",
    "closed_loop_stable_range",
    "closed_loop_state_space",
    "steer_feedback_terms",
]

Array = NDArray[Any]


class SteerFeedback(Protocol):
    """Gains ``[kφ, kδ, kφ̇, kδ̇]`` (N m/rad, N m s/rad) over speed, piecewise linear in ``v``.

    :class:`bike_rig.core.feedback.Feedback` is one.
    """

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Speeds (m/s) between which every gain is linear in ``v``."""

    def gains(self, v: ArrayLike) -> NDArray[np.float64]:
        """Gains at the speeds ``v`` (m/s), shape ``shape(v) + (4,)``."""


def steer_feedback_terms(p_rr: Sequence[Any], p_rs: Sequence[Any], gains: Sequence[Any]) -> list[Any]:
    """Coefficients ``[s⁰, s¹, s², s³]`` of ``(kδ + kδ̇ s) P_φφ(s) − (kφ + kφ̇ s) P_φδ(s)``.

    This is ``det P_cl(s) − det P(s)``: the determinant expanded along the steer row, to which
    the feedback adds ``[kφ + kφ̇ s, kδ + kδ̇ s]`` (units of ``det P``, kg² m⁴ s⁻⁴ per power of s).
    Only ``+`` and ``*``: the entries may be floats, arrays (real or complex) or
    :class:`numpy.polynomial.Polynomial` in ``v``.

    Args:
        p_rr: ``(m, c, k)`` of ``P_φφ(s) = m s² + c s + k``: ``Mφφ``, ``v C1φφ``,
            ``g K0φφ + v² K2φφ``.
        p_rs: The same for ``P_φδ``.
        gains: ``(kφ, kδ, kφ̇, kδ̇)``.
    """
    m0, c0, k0 = p_rr
    m1, c1, k1 = p_rs
    k_phi, k_delta, k_phidot, k_deltadot = gains
    return [
        k_delta * k0 - k_phi * k1,
        k_delta * c0 + k_deltadot * k0 - k_phi * c1 - k_phidot * k1,
        k_delta * m0 + k_deltadot * c0 - k_phi * m1 - k_phidot * c1,
        k_deltadot * m0 - k_phidot * m1,
    ]


def _row_entries(matrices: WhippleMatrices, g: Any, v: Any, col: int) -> tuple[Any, Any, Any]:
    """``(m, c, k)`` of ``P_φ,col(s)`` at the speed(s) ``v`` (broadcast with the batch)."""
    return (
        matrices.M[..., 0, col],
        v * matrices.C1[..., 0, col],
        g * matrices.K0[..., 0, col] + v * v * matrices.K2[..., 0, col],
    )


def _row_rates(matrices: WhippleMatrices, v: Any, col: int) -> tuple[Any, Any, Any]:
    """``d/dv`` of :func:`_row_entries`."""
    return (0.0 * matrices.M[..., 0, col], matrices.C1[..., 0, col] + 0.0 * v, 2.0 * v * matrices.K2[..., 0, col])


def closed_loop_rows(
    matrices: WhippleMatrices, g: Any, v: ArrayLike, gains: Array, slopes: Array | None = None
) -> tuple[list[Any], list[Any]]:
    """``a_k(v)`` of ``det P_cl(s) = Σ a_k s^k`` and ``d a_k/dv``, ``k = 0..4`` (ascending).

    Analytic in the matrices' entries (complex-step safe).

    Args:
        matrices: Canonical matrices, batch shape ``S``.
        g: Gravity (m/s²).
        v: Speed(s) (m/s), broadcast against ``S``.
        gains: ``[kφ, kδ, kφ̇, kδ̇]`` at ``v``, shape ``broadcast(S, v) + (4,)`` (or ``(4,)``).
        slopes: ``d gains/dv`` at ``v`` (same shape), for the derivatives; None: zero.

    Returns:
        Two lists of five arrays: ``a_k`` and ``d a_k/dv``.
    """
    speed = np.asarray(v)
    coef = characteristic_polynomial(matrices, g).coefficients
    powers = [speed**j for j in range(5)]
    rates = [0.0 * speed, 1.0 + 0.0 * speed, 2.0 * speed, 3.0 * speed**2, 4.0 * speed**3]
    a = [sum(coef[..., k, j] * powers[j] for j in range(5)) for k in range(5)]
    da = [sum(coef[..., k, j] * rates[j] for j in range(5)) for k in range(5)]
    k_now = [gains[..., i] for i in range(4)]
    rr, rs = _row_entries(matrices, g, speed, 0), _row_entries(matrices, g, speed, 1)
    extra = steer_feedback_terms(rr, rs, k_now)
    d_extra = steer_feedback_terms(_row_rates(matrices, speed, 0), _row_rates(matrices, speed, 1), k_now)
    if slopes is not None:
        k_rate = [slopes[..., i] for i in range(4)]
        d_extra = [x + y for x, y in zip(d_extra, steer_feedback_terms(rr, rs, k_rate), strict=True)]
    for k in range(4):
        a[k] = a[k] + extra[k]
        da[k] = da[k] + d_extra[k]
    return a, da


def closed_loop_coefficients(matrices: WhippleMatrices, g: Any, v: ArrayLike, gains: Array) -> Array:
    """Quartic coefficients ``[a4, a3, a2, a1, a0]`` (descending, :func:`numpy.roots` order).

    Of ``det(M s² + v C1 s + g K0 + v² K2 + [[0, 0], [kφ + kφ̇ s, kδ + kδ̇ s]])``, the
    characteristic polynomial of ``A − B K`` times ``det M``.

    Args:
        matrices: Canonical matrices, batch shape ``S``.
        g: Gravity (m/s²).
        v: Speed(s) (m/s).
        gains: ``[kφ, kδ, kφ̇, kδ̇]`` at ``v`` (N m/rad, N m s/rad), shape ``shape(v) + (4,)``.

    Returns:
        Shape ``broadcast(S, v) + (5,)``.
    """
    a, _ = closed_loop_rows(matrices, g, v, np.asarray(gains))
    return np.stack(np.broadcast_arrays(*a[::-1]), axis=-1)


def closed_loop_state_space(matrices: WhippleMatrices, v: ArrayLike, g: ArrayLike, gains: Array) -> tuple[Array, Array]:
    """``A − B K`` and ``B`` of the closed loop (``K = [[0, 0, 0, 0], gains]``), state ``[φ, δ, φ̇, δ̇]``.

    Args:
        matrices: Canonical matrices (one bicycle or a batch ``S``).
        v: Speed(s) (m/s).
        g: Gravity (m/s²).
        gains: ``[kφ, kδ, kφ̇, kδ̇]`` at ``v``, shape ``shape(v) + (4,)``.

    Returns:
        ``A − B K`` (1/s, 1/s²), shape as :func:`state_space`'s ``A``, and ``B`` (1/(kg m²)).
    """
    a, b = state_space(matrices, v, g)
    steer = b[..., :, 1:]  # (…, 4, 1): the steer-torque column
    return a - steer @ np.asarray(gains)[..., None, :], b


# --------------------------------------------------------------------------------------------
# Critical speeds: polynomial pieces between the schedule's breakpoints
# --------------------------------------------------------------------------------------------


def _gain_slopes(feedback: SteerFeedback, lo: float, hi: float) -> tuple[Array, Array]:
    """Gains ``α + β v`` on ``[lo, hi]`` (linear there): ``(α, β)``, each shape (4,)."""
    span = 1.0 if not math.isfinite(hi) else hi - lo
    probe = lo + 0.5 * span
    k_lo, k_mid = feedback.gains(lo), feedback.gains(probe)
    beta = (k_mid - k_lo) / (probe - lo)
    return k_lo - beta * lo, beta


def _piece(matrices: WhippleMatrices, g: float, alpha: Array, beta: Array) -> list[Polynomial]:
    """``a_k(v)``, ``k = 0..4``, as polynomials in ``v`` for gains ``α + β v``."""
    coef = np.asarray(characteristic_polynomial(matrices, g).coefficients, dtype=float)
    a = [Polynomial(coef[k]) for k in range(5)]
    rows = [
        (
            Polynomial([float(matrices.M[0, col])]),
            Polynomial([0.0, float(matrices.C1[0, col])]),
            Polynomial([g * float(matrices.K0[0, col]), 0.0, float(matrices.K2[0, col])]),
        )
        for col in (0, 1)
    ]
    gains = [Polynomial([float(alpha[i]), float(beta[i])]) for i in range(4)]
    extra = steer_feedback_terms(rows[0], rows[1], gains)
    return [a[k] + extra[k] if k < 4 else a[k] for k in range(5)]


def _real_roots(p: Polynomial, lo: float, hi: float) -> list[float]:
    """Real roots of ``p`` in ``[lo, hi]`` (companion matrix; near-real ones kept for polishing)."""
    p = p.trim()
    if p.degree() < 1:
        return []
    out = []
    for z in np.asarray(p.roots(), dtype=complex).tolist():
        if abs(z.imag) <= 1e-6 * max(1.0, abs(z.real)) and lo - 1e-9 <= z.real <= hi + 1e-9:
            out.append(z.real)
    return out


class _Evaluator:
    """``a_k(v)`` and ``d a_k/dv`` of one bicycle's closed loop at real speeds (normalised ``a4 = 1``)."""

    def __init__(self, matrices: WhippleMatrices, g: float, feedback: SteerFeedback):
        self.matrices, self.g, self.feedback = matrices, g, feedback
        self.lead = float(matrices.M[0, 0] * matrices.M[1, 1] - matrices.M[0, 1] * matrices.M[1, 0])

    def __call__(self, v: float, lo: float, hi: float) -> tuple[list[float], list[float]]:
        alpha, beta = _gain_slopes(self.feedback, lo, hi)
        a, da = closed_loop_rows(self.matrices, self.g, v, alpha + beta * v, beta)
        return [float(x) / self.lead for x in a], [float(x) / self.lead for x in da]


def _changes_sign(func: Any, v: float) -> bool:
    """Whether ``func(x)[0]`` changes sign across ``v`` (±1e-9 relative): a crossing, not a touch."""
    step = 1e-9 * max(1.0, abs(v))
    return bool(func(v - step)[0] * func(v + step)[0] < 0.0)


def _pieces(feedback: SteerFeedback, v_max: float) -> list[tuple[float, float]]:
    """Speed intervals of ``(0, v_max]`` on which every gain is linear."""
    edges = [0.0, *(b for b in feedback.breakpoints if 0.0 < b < v_max), v_max]
    return list(itertools.pairwise(edges))


def _crossings_on(ev: _Evaluator, lo: float, hi: float) -> list[tuple[float, str, Crossing | None]]:
    """Polished roots of ``a0`` and ``H`` in ``(lo, hi]``: ``(speed, kind, crossing or None)``."""
    alpha, beta = _gain_slopes(ev.feedback, lo, hi)
    a = [p / ev.lead for p in _piece(ev.matrices, ev.g, alpha, beta)]
    h = a[3] * a[2] * a[1] - a[4] * a[1] ** 2 - a[0] * a[3] ** 2
    found: list[tuple[float, str, Crossing | None]] = []

    def a0(x: float) -> tuple[float, float]:
        ak, dak = ev(x, lo, hi)
        return ak[0], dak[0]

    def hurwitz(x: float) -> tuple[float, float]:
        h_x, dh_x = hurwitz_determinant(*ev(x, lo, hi))
        return float(h_x), float(dh_x)

    for v0 in _real_roots(a[0], lo, hi):
        v = _newton(a0, v0)
        ak, dak = ev(v, lo, hi)
        ok = ak[1] != 0.0 and dak[0] != 0.0 and _changes_sign(a0, v)
        found.append((v, "real", Crossing(v, "real", 0.0, -dak[0] / ak[1]) if ok else None))
    for v0 in _real_roots(h, lo, hi):
        v = _newton(hurwitz, v0)
        ak, dak = ev(v, lo, hi)
        crossing = None
        if ak[3] != 0.0 and ak[1] / ak[3] > 0.0 and _changes_sign(hurwitz, v):
            omega = math.sqrt(ak[1] / ak[3])
            try:
                crossing = Crossing(v, "oscillatory", omega, float(pair_crossing_rate(ak, dak, omega)))
            except ZeroDivisionError:
                crossing = None
        found.append((v, "oscillatory", crossing))
    return [f for f in found if lo < f[0] <= hi]


def _all_roots(
    matrices: WhippleMatrices, g: float, feedback: SteerFeedback, v_max: float
) -> tuple[_Evaluator, list[tuple[float, str, Crossing | None]]]:
    check_one_bicycle(matrices)
    ev = _Evaluator(matrices, float(g), feedback)
    found = [f for lo, hi in _pieces(feedback, v_max) for f in _crossings_on(ev, lo, hi)]
    return ev, sorted(found, key=lambda f: f[0])


def closed_loop_critical_speeds(
    matrices: WhippleMatrices, g: float, feedback: SteerFeedback, v_max: float = math.inf
) -> CriticalSpeeds:
    """Weave and capsize speeds (m/s) of the closed loop, as :func:`.stability.critical_speeds`.

    On each piece of ``(0, v_max]`` where the gains are linear, the real roots of ``a0(v)`` and
    of the Hurwitz determinant (polynomials in ``v``) are the candidates; each is polished by
    Newton on the unexpanded coefficients and kept as a crossing when it is one (a real root
    with ``a0' ≠ 0``; a pair with ``ω² = a1/a3 > 0``). ``weave`` is the lowest stabilising
    oscillatory crossing and ``capsize`` the lowest destabilising real one.

    Args:
        matrices: Canonical matrices of one bicycle.
        g: Gravity (m/s²).
        feedback: The gains over speed.
        v_max: Only crossings in ``(0, v_max]`` count (m/s).

    Raises:
        ModelError: Matrices not of one real bicycle.
    """
    _, found = _all_roots(matrices, g, feedback, v_max)
    crossings = [c for _, _, c in found if c is not None]
    weave = next((c.speed for c in crossings if c.kind == "oscillatory" and c.rate < 0.0), None)
    capsize = next((c.speed for c in crossings if c.kind == "real" and c.rate > 0.0), None)
    return CriticalSpeeds(weave=weave, capsize=capsize, crossings=tuple(crossings))


def closed_loop_stable_range(
    matrices: WhippleMatrices, g: float, feedback: SteerFeedback, v_max: float = math.inf
) -> tuple[tuple[float, float], ...]:
    """Speed intervals within ``(0, v_max]`` where the closed loop is asymptotically stable.

    Split at every root of ``a0`` and ``H`` (crossing or not) and tested by Liénard–Chipart in
    the middle of each piece, as :func:`.stability.stable_speed_range`.

    Returns:
        Disjoint ``(low, high)`` intervals (m/s), increasing; ``high`` may be ``inf``.
    """
    ev, found = _all_roots(matrices, g, feedback, v_max)
    edges = [0.0, *sorted({f[0] for f in found if 0.0 < f[0] < v_max}), v_max]
    pieces = _pieces(feedback, v_max)
    out: list[tuple[float, float]] = []
    for lo, hi in itertools.pairwise(edges):
        probe = 0.5 * (lo + hi) if math.isfinite(hi) else 2.0 * lo + 1.0
        piece = next((p for p in pieces if p[0] <= probe <= p[1]), pieces[-1])
        a, da = ev(probe, *piece)
        if hi > lo and all(x > 0.0 for x in a) and hurwitz_determinant(a, da)[0] > 0.0:
            if out and out[-1][1] == lo:
                out[-1] = (out[-1][0], hi)
            else:
                out.append((lo, hi))
    return tuple(out)
