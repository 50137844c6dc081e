"""Linearised Whipple bicycle model (Meijaard, Papadopoulos, Ruina, Schwab 2007).

The model is ``M q̈ + v C1 q̇ + (g K0 + v² K2) q = f`` with ``q = [φ, δ]`` (roll, steer; rad)
and ``f = [T_φ, T_δ]`` (N m). This module provides

* :func:`canonical_matrices`: ``M, C1, K0, K2`` from the 26 benchmark parameters (paper
  Appendix A), as pure broadcasting arithmetic that also accepts complex values (for
  complex-step derivatives);
* :func:`state_space`: the first-order form ``ẋ = A x + B f``, ``x = [φ, δ, φ̇, δ̇]``;
* :func:`characteristic_polynomial` / :func:`characteristic_coefficients`:
  ``det(M s² + v C1 s + g K0 + v² K2)`` as a bivariate polynomial in ``s`` and ``v``;
* :func:`eigenvalues`: the four eigenvalues (1/s) over many speeds at once, by closed-form
  quartic roots, tracked across speeds and labelled weave / capsize / caster;
* :func:`critical_speeds` / :func:`stable_speed_range`: the weave and capsize speeds (m/s) from
  the Routh–Hurwitz structure of the quartic, in closed form and then polished.

Units are SI throughout: lengths in m, masses in kg, inertias in kg m², angles in rad, ``g`` in
m/s², speeds in m/s, eigenvalues in 1/s.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import ModelError
from .symbols import PARAMETER_NAMES as PARAMETER_KEYS

__all__ = [
    "MODE_LABELS",
    "PARAMETER_KEYS",
    "WhippleMatrices",
    "CharacteristicPolynomial",
    "CriticalSpeeds",
    "Crossing",
    "EigenvalueSweep",
    "canonical_matrices",
    "characteristic_coefficients",
    "characteristic_polynomial",
    "critical_speeds",
    "eigenvalues",
    "hurwitz_determinant",
    "quartic_roots",
    "stable_speed_range",
    "state_space",
]

#: Labels of the eigenvalue columns returned by :func:`eigenvalues`, in column order.
MODE_LABELS: tuple[str, str, str, str] = ("weave", "weave", "capsize", "caster")

Array = NDArray[Any]
FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]


# --------------------------------------------------------------------------------------------
# Canonical matrices (paper Appendix A)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class WhippleMatrices:
    """The canonical matrices of ``M q̈ + v C1 q̇ + (g K0 + v² K2) q = f``.

    Every array has shape ``batch_shape + (2, 2)``, rows and columns ordered [roll φ, steer δ].
    The dtype is float, or complex when a parameter was complex (complex-step use).

    Attributes:
        M: Mass matrix (kg m²).
        C1: Damping-like (gyroscopic) matrix, multiplied by v (kg m).
        K0: Gravity stiffness matrix, multiplied by g (kg m).
        K2: Speed stiffness matrix, multiplied by v² (kg).
    """

    M: Array
    C1: Array
    K0: Array
    K2: Array


def _param(p: Mapping[str, ArrayLike], key: str) -> Array:
    """One parameter as an array (complex values are kept)."""
    try:
        value = p[key]
    except KeyError:
        raise ModelError(f"benchmark parameter '{key}' is missing") from None
    return np.asarray(value)


def _total_mass_centre(p: Mapping[str, Array]) -> tuple[Array, Array, Array]:
    """Total mass ``mT`` (kg) and its centre ``xT, zT`` (m), paper Appendix A."""
    m_t = p["mR"] + p["mB"] + p["mH"] + p["mF"]
    x_t = (p["xB"] * p["mB"] + p["xH"] * p["mH"] + p["w"] * p["mF"]) / m_t
    z_t = (-p["rR"] * p["mR"] + p["zB"] * p["mB"] + p["zH"] * p["mH"] - p["rF"] * p["mF"]) / m_t
    return m_t, x_t, z_t


def _total_inertia(p: Mapping[str, Array]) -> tuple[Array, Array, Array]:
    """Total inertia ``ITxx, ITxz, ITzz`` (kg m²) about the rear contact (Appendix A).

    Uses the paper's symmetric-wheel assumption ``IRzz = IRxx`` and ``IFzz = IFxx``.
    """
    i_rzz, i_fzz = p["IRxx"], p["IFxx"]
    i_txx = (
        p["IRxx"] + p["IBxx"] + p["IHxx"] + p["IFxx"]
        + p["mR"] * p["rR"] ** 2 + p["mB"] * p["zB"] ** 2
        + p["mH"] * p["zH"] ** 2 + p["mF"] * p["rF"] ** 2
    )  # fmt: skip
    i_txz = (
        p["IBxz"] + p["IHxz"] - p["mB"] * p["xB"] * p["zB"]
        - p["mH"] * p["xH"] * p["zH"] + p["mF"] * p["w"] * p["rF"]
    )  # fmt: skip
    i_tzz = (
        i_rzz + p["IBzz"] + p["IHzz"] + i_fzz
        + p["mB"] * p["xB"] ** 2 + p["mH"] * p["xH"] ** 2 + p["mF"] * p["w"] ** 2
    )  # fmt: skip
    return i_txx, i_txz, i_tzz


def _front_mass_centre(p: Mapping[str, Array]) -> tuple[Array, Array, Array]:
    """Front assembly mass ``mA`` (kg) and centre ``xA, zA`` (m), Appendix A."""
    m_a = p["mH"] + p["mF"]
    x_a = (p["xH"] * p["mH"] + p["w"] * p["mF"]) / m_a
    z_a = (p["zH"] * p["mH"] - p["rF"] * p["mF"]) / m_a
    return m_a, x_a, z_a


def _front_inertia(p: Mapping[str, Array], x_a: Array, z_a: Array) -> tuple[Array, Array, Array]:
    """Front assembly inertia ``IAxx, IAxz, IAzz`` (kg m²) about its centre (App. A)."""
    i_axx = p["IHxx"] + p["IFxx"] + p["mH"] * (p["zH"] - z_a) ** 2 + p["mF"] * (p["rF"] + z_a) ** 2
    i_axz = (
        p["IHxz"] - p["mH"] * (p["xH"] - x_a) * (p["zH"] - z_a)
        + p["mF"] * (p["w"] - x_a) * (p["rF"] + z_a)
    )  # fmt: skip
    i_azz = p["IHzz"] + p["IFxx"] + p["mH"] * (p["xH"] - x_a) ** 2 + p["mF"] * (p["w"] - x_a) ** 2
    return i_axx, i_axz, i_azz


@dataclass(frozen=True)
class _SteerAxis:
    """Front assembly about the steer axis and ``μ`` (paper Appendix A).

    ``u_a`` (m) is the perpendicular distance of the front mass centre ahead of the steer axis,
    ``i_all, i_alx, i_alz`` (kg m²) the front inertia about the steer axis and its products,
    ``mu`` (-) the steer-axis ratio ``(c/w) cos λ``.
    """

    u_a: Array
    i_all: Array
    i_alx: Array
    i_alz: Array
    mu: Array


def _steer_axis(p: Mapping[str, Array], front: tuple[Array, ...], sin_l: Array, cos_l: Array) -> _SteerAxis:
    """Steer-axis quantities ``uA, IAll, IAlx, IAlz, μ`` (Appendix A)."""
    m_a, x_a, z_a, i_axx, i_axz, i_azz = front
    u_a = (x_a - p["w"] - p["c"]) * cos_l - z_a * sin_l
    i_all = m_a * u_a**2 + i_axx * sin_l**2 + 2 * i_axz * sin_l * cos_l + i_azz * cos_l**2
    i_alx = -m_a * u_a * z_a + i_axx * sin_l + i_axz * cos_l
    i_alz = m_a * u_a * x_a + i_axz * sin_l + i_azz * cos_l
    mu = p["c"] / p["w"] * cos_l
    return _SteerAxis(u_a, i_all, i_alx, i_alz, mu)


def _gyro_terms(
    p: Mapping[str, Array], m_a: Array, u_a: Array, mu: Array, m_t: Array, x_t: Array
) -> tuple[Array, Array, Array]:
    """Gyrostatic coefficients ``SF, ST`` and static moment ``SA`` (kg m), Appendix A.

    ``SR = IRyy/rR`` and ``SF = IFyy/rF`` are the wheels' angular momentum per unit speed.
    """
    s_r = p["IRyy"] / p["rR"]
    s_f = p["IFyy"] / p["rF"]
    s_t = s_r + s_f
    s_a = m_a * u_a + mu * m_t * x_t
    return s_f, s_t, s_a


def _stack2(a11: Any, a12: Any, a21: Any, a22: Any) -> Array:
    """Stack four broadcastable entries into an array of shape ``shape + (2, 2)``."""
    e = np.broadcast_arrays(*(np.asarray(x) for x in (a11, a12, a21, a22)))
    return np.stack([np.stack(e[:2], axis=-1), np.stack(e[2:], axis=-1)], axis=-2)


def canonical_matrices(p: Mapping[str, ArrayLike]) -> WhippleMatrices:
    """Canonical matrices ``M, C1, K0, K2`` from the benchmark parameters (paper Appendix A).

    The computation is elementwise ``+ - * / ** sin cos`` only, so every parameter may be a
    float or an array of any (broadcastable) shape, real or complex: a complex input with a
    tiny imaginary perturbation ``h`` gives ``Im(result)/h`` as the exact derivative
    (complex-step differentiation).

    Args:
        p: The 26 benchmark parameters keyed as in :data:`PARAMETER_KEYS` (SI units, ``lam`` in
            rad). ``g`` is not used here (``K0`` is per unit gravity).

    Returns:
        The matrices, each of shape ``broadcast_shape + (2, 2)``.

    Raises:
        ModelError: A parameter is missing.
    """
    q = {k: _param(p, k) for k in PARAMETER_KEYS if k != "g"}
    sin_l, cos_l = np.sin(q["lam"]), np.cos(q["lam"])
    m_t, x_t, z_t = _total_mass_centre(q)
    i_txx, i_txz, i_tzz = _total_inertia(q)
    m_a, x_a, z_a = _front_mass_centre(q)
    front = (m_a, x_a, z_a, *_front_inertia(q, x_a, z_a))
    ax = _steer_axis(q, front, sin_l, cos_l)
    s_f, s_t, s_a = _gyro_terms(q, m_a, ax.u_a, ax.mu, m_t, x_t)
    w = q["w"]
    # M (Appendix A): Mφφ = ITxx, Mφδ = IAlx + μ ITxz, Mδδ = IAll + 2μ IAlz + μ² ITzz.
    m_pd = ax.i_alx + ax.mu * i_txz
    m_dd = ax.i_all + 2 * ax.mu * ax.i_alz + ax.mu**2 * i_tzz
    mass = _stack2(i_txx, m_pd, m_pd, m_dd)
    # K0: K0φφ = mT zT, K0φδ = K0δφ = -SA, K0δδ = -SA sin λ.
    k0 = _stack2(m_t * z_t, -s_a, -s_a, -s_a * sin_l)
    # K2 (first column zero): K2φδ = (ST - mT zT) cos λ / w, K2δδ = (SA + SF sin λ) cos λ / w.
    k2 = _stack2(0.0 * w, (s_t - m_t * z_t) / w * cos_l, 0.0 * w, (s_a + s_f * sin_l) / w * cos_l)
    # C1: C1φδ = μ ST + SF cos λ + ITxz cos λ / w - μ mT zT, C1δφ = -(μ ST + SF cos λ),
    #     C1δδ = IAlz cos λ / w + μ (SA + ITzz cos λ / w).
    c_pd = ax.mu * s_t + s_f * cos_l + i_txz / w * cos_l - ax.mu * m_t * z_t
    c_dp = -(ax.mu * s_t + s_f * cos_l)
    c_dd = ax.i_alz / w * cos_l + ax.mu * (s_a + i_tzz / w * cos_l)
    c1 = _stack2(0.0 * w, c_pd, c_dp, c_dd)
    shape = np.broadcast_shapes(*(a.shape for a in q.values())) + (2, 2)
    dtype = np.result_type(*q.values(), float)  # complex for all four if any input is
    mats = [np.array(np.broadcast_to(x, shape), dtype=dtype) for x in (mass, c1, k0, k2)]
    return WhippleMatrices(M=mats[0], C1=mats[1], K0=mats[2], K2=mats[3])


# --------------------------------------------------------------------------------------------
# First-order form and characteristic polynomial
# --------------------------------------------------------------------------------------------


def _det2(a: Array) -> Array:
    """Determinant of ``(..., 2, 2)`` arrays, in closed form (analytic, no conjugation)."""
    return a[..., 0, 0] * a[..., 1, 1] - a[..., 0, 1] * a[..., 1, 0]


def _mixed_det(a: Array, b: Array) -> Array:
    """Mixed determinant ``D(a, b)`` with ``det(a + b) = det a + D(a, b) + det b`` (2x2)."""
    return (
        a[..., 0, 0] * b[..., 1, 1] + b[..., 0, 0] * a[..., 1, 1]
        - a[..., 0, 1] * b[..., 1, 0] - b[..., 0, 1] * a[..., 1, 0]
    )  # fmt: skip


def _inverse2(a: Array) -> Array:
    """Closed-form inverse of ``(..., 2, 2)`` arrays."""
    adj = np.stack(
        [np.stack([a[..., 1, 1], -a[..., 0, 1]], -1), np.stack([-a[..., 1, 0], a[..., 0, 0]], -1)],
        axis=-2,
    )
    return adj / _det2(a)[..., None, None]


def state_space(matrices: WhippleMatrices, v: ArrayLike, g: ArrayLike) -> tuple[Array, Array]:
    """First-order form ``ẋ = A x + B u`` with ``x = [φ, δ, φ̇, δ̇]`` and ``u = [T_φ, T_δ]``.

    ``A = [[0, I], [-M⁻¹(g K0 + v² K2), -M⁻¹ v C1]]`` and ``B = [[0], [M⁻¹]]``, with the 2x2
    inverse in closed form.

    Args:
        matrices: Canonical matrices of batch shape ``S``.
        v: Forward speed(s) (m/s), scalar or array broadcastable against ``S`` (typically
            shape ``(N,)`` with ``S = ()``).
        g: Gravity (m/s²).

    Returns:
        ``A`` of shape ``broadcast(S, v.shape) + (4, 4)`` (1/s, 1/s²) and ``B`` of shape
        ``S + (4, 2)`` (1/(kg m²)), which does not depend on the speed.

    Raises:
        ModelError: The mass matrix is singular.
    """
    det_m = _det2(matrices.M)
    if np.any(det_m == 0):
        raise ModelError("the mass matrix M is singular")
    m_inv = _inverse2(matrices.M)
    speed = np.asarray(v)[..., None, None]
    stiff = -m_inv @ (np.asarray(g) * matrices.K0 + speed**2 * matrices.K2)
    damp = -m_inv @ (speed * matrices.C1)
    stiff, damp = np.broadcast_arrays(stiff, damp)
    top = np.concatenate([np.zeros_like(stiff), np.broadcast_to(np.eye(2), stiff.shape)], axis=-1)
    a = np.concatenate([top, np.concatenate([stiff, damp], axis=-1)], axis=-2)
    b = np.concatenate([np.zeros_like(m_inv), m_inv], axis=-2)
    return a, b


@dataclass(frozen=True)
class CharacteristicPolynomial:
    """``det(M s² + v C1 s + g K0 + v² K2) = Σ_kj coefficients[..., k, j] s^k v^j``.

    Only these entries can be non-zero (``D`` is the mixed determinant, ``det(A+B) = det A +
    D(A, B) + det B``)::

        s⁴:       det M
        s³ v:     D(M, C1)
        s²:       g D(M, K0)          s² v²: D(M, K2) + det C1
        s v:      g D(C1, K0)         s v³:  D(C1, K2)
        1:        g² det K0           v²:    g D(K0, K2)           v⁴: det K2

    so ``a3`` and ``a1`` are odd in ``v`` and ``a4, a2, a0`` even. The array is
    ``np.polynomial.polynomial.polyval2d(s, v, coefficients)``-compatible.

    Attributes:
        coefficients: Shape ``S + (5, 5)``; index ``[k, j]`` multiplies ``s**k * v**j``
            (``s`` in 1/s, ``v`` in m/s; the determinant is in kg² m⁴ s⁻⁴, so entry
            ``[k, j]`` is in kg² m^(4-j) s^(k+j-4)).
    """

    coefficients: Array

    def at_speed(self, v: ArrayLike) -> Array:
        """Quartic coefficients ``[a4, a3, a2, a1, a0]`` (descending powers of s) at ``v``.

        Args:
            v: Speed(s) (m/s), broadcastable against the batch shape.

        Returns:
            Array of shape ``broadcast(S, v.shape) + (5,)``, in :func:`numpy.roots` order.
        """
        speed = np.asarray(v)[..., None]
        powers = speed ** np.arange(5)
        a = np.sum(self.coefficients[..., None, :, :] * powers[..., None, :], axis=-1)
        return np.asarray(a[..., ::-1])


def characteristic_polynomial(matrices: WhippleMatrices, g: ArrayLike) -> CharacteristicPolynomial:
    """Coefficients of the characteristic polynomial as polynomials in the speed ``v``.

    Analytic in the matrix entries (complex input is allowed).

    Args:
        matrices: Canonical matrices, batch shape ``S``.
        g: Gravity (m/s²).

    Returns:
        The polynomial, coefficients of shape ``S + (5, 5)``.
    """
    m, c1, k0, k2 = matrices.M, matrices.C1, matrices.K0, matrices.K2
    grav = np.asarray(g)
    det_m = _det2(m)
    out = np.zeros(
        np.broadcast_shapes(det_m.shape, grav.shape) + (5, 5), dtype=np.result_type(m, c1, k0, k2, grav, float)
    )
    out[..., 4, 0] = det_m
    out[..., 3, 1] = _mixed_det(m, c1)
    out[..., 2, 0] = grav * _mixed_det(m, k0)
    out[..., 2, 2] = _mixed_det(m, k2) + _det2(c1)
    out[..., 1, 1] = grav * _mixed_det(c1, k0)
    out[..., 1, 3] = _mixed_det(c1, k2)
    out[..., 0, 0] = grav**2 * _det2(k0)
    out[..., 0, 2] = grav * _mixed_det(k0, k2)
    out[..., 0, 4] = _det2(k2)
    return CharacteristicPolynomial(coefficients=out)


def characteristic_coefficients(matrices: WhippleMatrices, g: ArrayLike, v: ArrayLike) -> Array:
    """Quartic coefficients ``[a4, a3, a2, a1, a0]`` of ``det(M s² + v C1 s + g K0 + v² K2)``.

    Args:
        matrices: Canonical matrices, batch shape ``S``.
        g: Gravity (m/s²).
        v: Speed(s) (m/s), e.g. shape ``(N,)``.

    Returns:
        Shape ``broadcast(S, v.shape) + (5,)``, descending powers of ``s`` (``numpy.roots``
        order).
    """
    return characteristic_polynomial(matrices, g).at_speed(v)


# --------------------------------------------------------------------------------------------
# Closed-form quartic roots (Ferrari with a real resolvent root), vectorised
# --------------------------------------------------------------------------------------------


def _safe_divide(num: FloatArray, den: FloatArray, fallback: FloatArray | float) -> FloatArray:
    """``num / den`` where ``den != 0``, else ``fallback``, without floating-point warnings."""
    out = np.array(np.broadcast_to(fallback, np.broadcast_shapes(num.shape, den.shape)), dtype=float)
    np.divide(num, den, out=out, where=den != 0)
    return out


def _largest_resolvent_root(p: FloatArray, q: FloatArray, r: FloatArray) -> FloatArray:
    """Largest real root ``t ≥ 0`` of the resolvent cubic ``t³ + 2p t² + (p² - 4r) t - q²``.

    For ``y⁴ + p y² + q y + r = (y² + S y + P1)(y² - S y + P2)`` the resolvent's roots are
    ``t = S²``; its value at 0 is ``-q² ≤ 0``, so a real root ``t ≥ 0`` always exists and ``S``
    is real. Cardano (one real root) or the trigonometric form (three real roots) give the
    start; a Newton step on the cubic polishes it. Call under ``np.errstate(all="ignore")``:
    divisions by zero only produce values that are replaced or rejected.
    """
    p2, q2 = p * p, q * q
    a2, a1 = 2.0 * p, p2 - 4.0 * r
    # Depressed cubic x³ + P x + Q with t = x - 2p/3: third = P/3, half = -Q/2.
    third = -(p2 / 9.0) - (4.0 / 3.0) * r
    half = p * (p2 / 27.0 - (4.0 / 3.0) * r) + 0.5 * q2
    disc = half * half + third * third * third  # (not ** 3: numpy's pow is ~50x slower)
    u = np.cbrt(half + np.copysign(np.sqrt(np.maximum(disc, 0.0)), half))
    x = u - third / u  # u = 0 only where disc <= 0, replaced below
    three = np.flatnonzero(disc <= 0.0)
    if three.size:
        m = np.sqrt(np.maximum(-third[three], 0.0))
        cos_arg = np.clip(_safe_divide(half[three], m * m * m, 0.0), -1.0, 1.0)
        x[three] = 2.0 * m * np.cos(np.arccos(cos_arg) / 3.0)
    t = x - (2.0 / 3.0) * p
    # One Newton step (more changes nothing measurable; none leaves ~1e-8 errors at v = 0),
    # kept only where it lowers |f|: at a multiple root f' is rounding noise (NaN steps from
    # f' = 0 compare false and are dropped too).
    f = ((t + a2) * t + a1) * t - q2
    t_new = t - f / ((3.0 * t + 2.0 * a2) * t + a1)
    f_new = ((t_new + a2) * t_new + a1) * t_new - q2
    return np.maximum(np.where(np.abs(f_new) <= np.abs(f), t_new, t), 0.0)


def _quadratic_into(bq: FloatArray, cq: FloatArray, re: FloatArray, im: FloatArray) -> None:
    """Roots of ``s² + bq s + cq`` into rows ``re[0:2], im[0:2]`` (views of length N).

    Row 0 holds the larger real root or the root with ``Im > 0``. The root of larger
    magnitude comes from the cancellation-free formula and the smaller one from the product
    ``cq``, so small roots keep their relative accuracy. Call under
    ``np.errstate(all="ignore")`` (``0/0`` at ``bq = cq = 0`` is dropped by ``fmax/fmin``).
    """
    disc = bq * bq - 4.0 * cq
    root = np.sqrt(np.abs(disc))
    cplx = disc < 0.0
    big = -0.5 * (bq + np.copysign(root, bq))
    small = cq / big
    np.fmax(big, small, out=re[0])
    np.fmin(big, small, out=re[1])
    centre = -0.5 * bq
    np.copyto(re[0], centre, where=cplx)
    np.copyto(re[1], centre, where=cplx)
    np.multiply(root, 0.5, out=im[0])
    np.copyto(im[0], 0.0, where=~cplx)
    np.negative(im[0], out=im[1])


def _monic_quartic_parts(b: FloatArray, c: FloatArray, d: FloatArray, e: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Roots of ``s⁴ + b s³ + c s² + d s + e`` (real 1-D arrays) as real and imaginary parts.

    Returns:
        ``(re, im)``, each of shape ``(4, N)``, in *factor order*: rows 0-1 are the roots of the
        quadratic factor ``s² + (b/2 + S) s + C1``, rows 2-3 those of ``s² + (b/2 - S) s +
        C2``; within a factor the larger real root, or the root with positive imaginary part,
        comes first (complex roots always form conjugate pairs within one factor). Where the
        factorisation fails its check (:func:`_factor_mismatch`), the column comes from
        :func:`_companion_parts` instead.
    """
    re = np.empty((4, b.size))
    im = np.empty((4, b.size))
    _quartic_into(b, c, d, e, re, im)
    return re, im


def _quartic_into(b: FloatArray, c: FloatArray, d: FloatArray, e: FloatArray, re: FloatArray, im: FloatArray) -> None:
    """:func:`_monic_quartic_parts` writing into given ``(4, N)`` arrays (or views)."""
    with np.errstate(all="ignore"):
        suspect = _ferrari(b, c, d, e, re, im)
    if suspect.size:
        re[:, suspect], im[:, suspect] = _companion_parts(b[suspect], c[suspect], d[suspect], e[suspect])


def _ferrari(
    b: FloatArray, c: FloatArray, d: FloatArray, e: FloatArray, re: FloatArray, im: FloatArray
) -> NDArray[np.intp]:
    """Body of :func:`_quartic_into`; returns the columns that fail the factor check."""
    bb = b * b
    # Depressed quartic y⁴ + p y² + q y + r with s = y - b/4.
    p = c - 0.375 * bb
    q = d + b * (0.125 * bb - 0.5 * c)
    r = e + b * (-0.25 * d + b * (c / 16.0 - 3.0 * bb / 256.0))
    t = _largest_resolvent_root(p, q, r)
    s_ = np.sqrt(t)
    # P2 - P1 = q/S; also (q/S)² = (p + t)² - 4r since t is a resolvent root. The quotient
    # loses accuracy when t is small (and is 0/0 at t = q = 0), the square root when the
    # difference cancels: take the one with the smaller first-order error.
    pt = p + t
    w2 = pt * pt - 4.0 * r
    use_root = (w2 > t * (np.abs(pt) + np.sqrt(np.abs(r)))) | (s_ == 0.0)
    q_over_s = np.where(use_root, np.copysign(np.sqrt(np.maximum(w2, 0.0)), q), q / s_)
    common = bb / 16.0 + 0.5 * pt
    skew = 0.25 * s_ * b - 0.5 * q_over_s
    c1, c2 = common + skew, common - skew
    # C1 C2 = e exactly: recompute the smaller constant term from the larger one.
    first_big = np.abs(c1) >= np.abs(c2)
    np.divide(e, c1, out=c2, where=first_big & (c1 != 0.0))
    np.divide(e, c2, out=c1, where=~first_big & (c2 != 0.0))
    half_b = 0.5 * b
    b1, b2 = half_b + s_, half_b - s_
    _quadratic_into(b1, c1, re[0:2], im[0:2])
    _quadratic_into(b2, c2, re[2:4], im[2:4])
    return np.flatnonzero(_factor_mismatch(b1, c1, b2, c2, c, d))


def _factor_mismatch(
    b1: FloatArray, c1: FloatArray, b2: FloatArray, c2: FloatArray, c: FloatArray, d: FloatArray
) -> NDArray[np.bool_]:
    """Where ``(s² + b1 s + c1)(s² + b2 s + c2)`` misses ``c`` or ``d`` by > 1e-12 R² or R³.

    ``R`` bounds the roots' moduli; ``b`` and ``e`` hold by construction. This catches the
    rare inputs on which Ferrari's depressed form is inaccurate (three roots clustered far
    from the fourth, relative to the shift ``b/4``), for which the caller then uses
    :func:`_companion_parts`.
    """
    radius = np.maximum(np.abs(b1) + np.sqrt(np.abs(c1)), np.abs(b2) + np.sqrt(np.abs(c2)))
    r2 = radius * radius
    bad_c = np.abs(c1 + c2 + b1 * b2 - c) > 1e-12 * r2
    bad_d = np.abs(b1 * c2 + b2 * c1 - d) > 1e-12 * r2 * radius
    return np.asarray(bad_c | bad_d)


def _companion_parts(b: FloatArray, c: FloatArray, d: FloatArray, e: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Roots by eigenvalues of companion matrices (fallback), ``(re, im)`` of shape (4, n).

    Ordered by decreasing real part, then imaginary part (not in factor order).
    """
    comp = np.zeros((b.size, 4, 4))
    comp[:, 0, :] = -np.stack([b, c, d, e], axis=-1)
    comp[:, [1, 2, 3], [0, 1, 2]] = 1.0
    roots = -np.sort_complex(-np.linalg.eigvals(comp))
    return np.asarray(roots.real.T, dtype=float), np.asarray(roots.imag.T, dtype=float)


def quartic_roots(coefficients: ArrayLike) -> ComplexArray:
    """All roots of real quartics ``a4 s⁴ + a3 s³ + a2 s² + a1 s + a0``, vectorised.

    Closed form (Ferrari with the real non-negative resolvent root), then two guarded Newton
    steps per root; no iteration over elements. Errors are near those of a backward-stable
    method: about ``1e-15 · |root scale|`` for well-separated roots, growing to
    ``~1e-8 · scale`` at double roots.

    Args:
        coefficients: Real array of shape ``(..., 5)``, descending powers (``numpy.roots``
            order), with ``a4 != 0``.

    Returns:
        Complex array ``(..., 4)`` in factor order (see :func:`_monic_quartic_parts`).

    Raises:
        ModelError: Complex or non-finite coefficients, or ``a4 == 0``.
    """
    coef = np.asarray(coefficients)
    if np.iscomplexobj(coef) or coef.shape[-1:] != (5,):
        raise ModelError("quartic coefficients must be real with last axis of length 5")
    coef = coef.astype(float).reshape(-1, 5)
    if not np.all(np.isfinite(coef)) or np.any(coef[:, 0] == 0):
        raise ModelError("quartic coefficients must be finite with a non-zero leading term")
    lead = coef[:, 0]
    re, im = _monic_quartic_parts(*(coef[:, k] / lead for k in range(1, 5)))
    out = _newton_polish(coef, (re + 1j * im).T)
    return np.asarray(out.reshape(np.shape(coefficients)[:-1] + (4,)))


def _newton_polish(coef: FloatArray, z: ComplexArray, steps: int = 2) -> ComplexArray:
    """Newton steps on each root of the quartics ``coef`` (shape (N, 5)); roots (N, 4).

    A step is kept only where it lowers ``|p(z)|`` (so double roots cannot be thrown off).
    Ferrari's depressed form loses accuracy when ``|a3/a4|`` is large against some roots;
    this restores backward stability for general quartics. The speed sweep does not need it
    (bicycle quartics are well scaled) and skips it for speed.
    """
    c = coef[:, :, None]
    for _ in range(steps):
        p, dp = c[:, 0] * np.ones_like(z), np.zeros_like(z)
        for k in range(1, 5):
            dp = dp * z + p
            p = p * z + c[:, k]
        with np.errstate(over="ignore", invalid="ignore"):
            new = z - _safe_complex_divide(p, dp)
            p_new = np.zeros_like(z)
            for k in range(5):
                p_new = p_new * new + c[:, k]
        z = np.where(np.abs(p_new) < np.abs(p), new, z)
    return z


def _safe_complex_divide(num: ComplexArray, den: ComplexArray) -> ComplexArray:
    """``num / den`` where ``den != 0``, else 0."""
    out = np.zeros(np.broadcast_shapes(num.shape, den.shape), dtype=complex)
    np.divide(num, den, out=out, where=den != 0)
    return out


# --------------------------------------------------------------------------------------------
# Mode tracking across speeds
# --------------------------------------------------------------------------------------------

#: All 24 permutations of 4 columns; row 0 is the identity (so ties keep the columns).
_PERMS: NDArray[np.intp] = np.array(list(itertools.permutations(range(4))), dtype=np.intp)
_PERM_INDEX = {tuple(int(i) for i in row): code for code, row in enumerate(_PERMS)}
#: ``_COMPOSE[a, b]`` is the code of ``_PERMS[a][_PERMS[b]]`` (apply b, then a).
_COMPOSE: NDArray[np.intp] = np.array(
    [[_PERM_INDEX[tuple(int(i) for i in pa[pb])] for pb in _PERMS] for pa in _PERMS], dtype=np.intp
)
_PAIRS = tuple(itertools.combinations(range(4), 2))
#: Speeds per block of the vectorised passes: keeps their temporaries in cache (~2x faster
#: than whole 100k arrays on a 2-core machine).
_BLOCK = 8192
#: Up to this many constant-permutation segments are gathered by slices, beyond by indexing.
_MAX_SEGMENTS = 64


def _flagged_steps(re: FloatArray, im: FloatArray) -> NDArray[np.intp]:
    """Steps ``i → i+1`` at which keeping the columns is not provably the best matching.

    If every root moved by less than half the smallest distance ``δ`` between the roots at
    speed ``i``, any other matching pairs some root with a different one, at a distance
    ``> δ - δ/2 = δ/2``, more than the identity pays for it; so the identity is the unique
    minimum of the summed distances. Only the other steps (branch points, coincident roots,
    reordering of the closed-form factors, coarse grids) need the full search.

    Args:
        re: Real parts, shape ``(4, n)`` (rows in factor order, columns by speed).
        im: Imaginary parts, same shape.

    Returns:
        Indices ``i`` (``0 <= i < n - 1``) of the flagged steps.
    """
    d_re, d_im = np.diff(re, axis=1), np.diff(im, axis=1)
    move = (d_re * d_re + d_im * d_im).max(axis=0)
    gap = np.full(move.shape, np.inf)
    for j, k in _PAIRS:
        g_re = re[j, :-1] - re[k, :-1]
        g_im = im[j, :-1] - im[k, :-1]
        np.minimum(gap, g_re * g_re + g_im * g_im, out=gap)
    return np.flatnonzero(4.0 * move >= gap)


def _best_step_permutations(re: FloatArray, im: FloatArray, steps: NDArray[np.intp]) -> NDArray[np.intp]:
    """Codes of the minimum summed-distance matchings at the given steps (ties → identity).

    Code ``c`` means: root ``j`` at speed ``i`` continues as root ``_PERMS[c][j]`` at ``i+1``.
    """
    before = (re[:, steps] + 1j * im[:, steps]).T
    after = (re[:, steps + 1] + 1j * im[:, steps + 1]).T
    cost = np.abs(after[:, _PERMS] - before[:, None, :]).sum(axis=-1)
    return np.asarray(np.argmin(cost, axis=1), dtype=np.intp)


def _prefix_compose(codes: NDArray[np.intp]) -> NDArray[np.intp]:
    """Inclusive prefix compositions ``codes[f] ∘ … ∘ codes[0]`` by log-doubling (Hillis–Steele)."""
    cum = codes.copy()
    shift = 1
    while shift < cum.size:
        cum[shift:] = _COMPOSE[cum[shift:], cum[:-shift]]
        shift *= 2
    return cum


def _track(re: FloatArray, im: FloatArray, steps: NDArray[np.intp]) -> NDArray[np.intp]:
    """Permutation code per (sorted) speed mapping tracked column ``k`` to factor-order row.

    Args:
        re: Real parts of the roots, shape ``(4, N)``, columns by increasing speed.
        im: Imaginary parts, same shape.
        steps: The flagged steps (see :func:`_flagged_steps`); all others keep the rows.

    Returns:
        ``codes`` of shape ``(N,)``: the root on track ``k`` at speed ``i`` is row
        ``_PERMS[codes[i]][k]`` of column ``i``.
    """
    n = re.shape[1]
    if steps.size == 0:
        return np.zeros(n, dtype=np.intp)
    cum = _prefix_compose(_best_step_permutations(re, im, steps))
    before = np.zeros(n, dtype=np.intp)
    before[steps + 1] = 1
    return np.concatenate([np.zeros(1, dtype=np.intp), cum])[np.cumsum(before)]


def _label_order(z: ComplexArray) -> list[int]:
    """Tracks (indices into the four roots ``z`` at the highest speed) in MODE_LABELS order.

    * One conjugate pair: it is the weave (positive imaginary part first); of the two real
      roots the larger is capsize, the smaller caster.
    * Four real roots (low speed): the two largest are weave (they are the two unstable
      inverted-pendulum roots that merge into the weave pair as speed rises), then capsize,
      then caster.
    * Two conjugate pairs: the pair of larger frequency ``|Im s|`` is the weave; the other pair
      is the coupled capsize–caster oscillation, its ``Im s > 0`` member labelled capsize and
      ``Im s < 0`` caster.
    """
    cols = range(4)
    cplx = [k for k in cols if z[k].imag != 0]
    real = sorted((k for k in cols if z[k].imag == 0), key=lambda k: -z[k].real)
    if len(cplx) == 2:
        return sorted(cplx, key=lambda k: -z[k].imag) + real
    if not cplx:
        return real
    return sorted(cols, key=lambda k: (-abs(z[k].imag), -z[k].imag))


# --------------------------------------------------------------------------------------------
# Eigenvalue sweep
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class EigenvalueSweep:
    """Eigenvalues of the Whipple model over a set of speeds, tracked and labelled.

    Attributes:
        speeds: Speeds (m/s), shape ``(N,)``, in the order given by the caller.
        eigenvalues: Shape ``(N, 4)`` complex (1/s); row ``i`` belongs to ``speeds[i]``,
            column ``j`` to mode ``labels[j]`` (stored column-major: the transpose of a
            ``(4, N)`` array, so each mode's column is contiguous).
        labels: Mode of each column, always :data:`MODE_LABELS`
            ``("weave", "weave", "capsize", "caster")``.
        eigenvectors: ``None``, or shape ``(N, 4, 4)`` complex: ``eigenvectors[i, :, j]`` is
            the state-space eigenvector ``x = [φ, δ, sφ, sδ]`` of ``eigenvalues[i, j]``,
            scaled to unit 2-norm with its larger-modulus component of ``(φ, δ)`` real and
            positive.
    """

    speeds: FloatArray
    eigenvalues: ComplexArray
    labels: tuple[str, ...] = MODE_LABELS
    eigenvectors: ComplexArray | None = None

    def mode(self, label: str) -> ComplexArray:
        """The columns of one mode, shape ``(N, k)`` (k = 2 for weave, 1 otherwise).

        Raises:
            ModelError: Unknown label.
        """
        cols = [j for j, name in enumerate(self.labels) if name == label]
        if not cols:
            raise ModelError(f"unknown mode '{label}', expected one of {sorted(set(self.labels))}")
        return self.eigenvalues[:, cols]


def _scalar_matrices(matrices: WhippleMatrices) -> None:
    """Check that the matrices describe one real bicycle."""
    for name in ("M", "C1", "K0", "K2"):
        mat = np.asarray(getattr(matrices, name))
        if mat.shape != (2, 2) or np.iscomplexobj(mat) or not np.all(np.isfinite(mat)):
            raise ModelError(f"{name} must be one real, finite 2x2 matrix, got shape {mat.shape}")
    if _det2(np.asarray(matrices.M)) == 0:
        raise ModelError("the mass matrix M is singular")


def _speed_array(speeds: ArrayLike) -> FloatArray:
    """Speeds as a finite 1-D float array."""
    arr = np.asarray(speeds)
    if np.iscomplexobj(arr):
        raise ModelError("speeds must be real")
    arr = np.atleast_1d(arr.astype(float))
    if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
        raise ModelError("speeds must be a non-empty 1-D array of finite values (m/s)")
    return arr


def _monic_speed_coefficients(coef: FloatArray, v: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Monic quartic coefficients ``b, c, d, e`` at the speeds ``v`` from ``coef[k, j]``."""
    e_ = coef / coef[4, 0]
    u = v * v
    b = e_[3, 1] * v
    c = e_[2, 0] + e_[2, 2] * u
    d = v * (e_[1, 1] + e_[1, 3] * u)
    e = e_[0, 0] + u * (e_[0, 2] + e_[0, 4] * u)
    return b, c, d, e


def _abs2(z: ComplexArray) -> FloatArray:
    """``|z|²`` without the square root (and without numpy's slow complex ``abs ** 2``)."""
    return np.asarray(z.real * z.real + z.imag * z.imag)


def _eigenvector_block(entries: list[tuple[float, ...]], v: FloatArray, s: ComplexArray) -> ComplexArray:
    """Eigenvectors (see :func:`_eigenvectors`) for one block of speeds ``v`` and roots ``s``."""
    vv = v[:, None]
    s2 = s * s
    mat = [m * s2 + (c1 * vv) * s + (k0 + k2 * vv * vv) for m, c1, k0, k2 in entries]
    p00, p01, p10, p11 = mat
    first = (_abs2(p00) + _abs2(p01)) >= (_abs2(p10) + _abs2(p11))
    phi = np.where(first, p01, p11)
    delta = np.where(first, -p00, -p10)
    a_phi, a_delta = _abs2(phi), _abs2(delta)
    ref = np.where(a_phi >= a_delta, phi, delta)
    # ||[q, s q]||² = ||q||² (1 + |s|²); divide by the phase of ref and by the norm.
    scale = np.conj(ref) / np.sqrt(np.maximum(a_phi, a_delta) * (a_phi + a_delta) * (1.0 + _abs2(s)))
    phi *= scale
    delta *= scale
    return np.stack([phi, delta, s * phi, s * delta], axis=-2)


def _eigenvectors(matrices: WhippleMatrices, g: float, v: FloatArray, s: ComplexArray) -> ComplexArray:
    """State-space eigenvectors ``[q, s q]`` with ``(M s² + v C1 s + g K0 + v² K2) q = 0``.

    ``q`` is orthogonal to the larger row of the singular 2x2 matrix, so it is exact for a
    simple root; scaled to unit 2-norm with the larger of ``|φ|, |δ|`` real positive.
    """
    entries = [
        tuple(float(x) for x in (matrices.M[i, j], matrices.C1[i, j], g * matrices.K0[i, j], matrices.K2[i, j]))
        for i, j in ((0, 0), (0, 1), (1, 0), (1, 1))
    ]
    out = np.empty(s.shape[:1] + (4, 4), dtype=complex)
    for lo in range(0, v.size, _BLOCK):
        block = slice(lo, lo + _BLOCK)
        out[block] = _eigenvector_block(entries, v[block], s[block])
    return out


def _sorted_roots(coef: FloatArray, v: FloatArray) -> tuple[FloatArray, FloatArray, NDArray[np.intp]]:
    """Quartic roots at the sorted speeds ``v``, block by block, and the flagged steps.

    Returns:
        ``(re, im, steps)``: roots of shape ``(4, N)`` in factor order, and the steps that
        :func:`_flagged_steps` flags (computed per block while it is in cache).
    """
    n = v.size
    re = np.empty((4, n))
    im = np.empty((4, n))
    steps = [np.zeros(0, dtype=np.intp)]
    for lo in range(0, n, _BLOCK):
        hi = min(lo + _BLOCK, n)
        _quartic_into(*_monic_speed_coefficients(coef, v[lo:hi]), re[:, lo:hi], im[:, lo:hi])
        start = max(lo - 1, 0)  # include the step from the previous block
        steps.append(_flagged_steps(re[:, start:hi], im[:, start:hi]) + start)
    return re, im, np.concatenate(steps)


def _gather(
    re: FloatArray,
    im: FloatArray,
    table: NDArray[np.intp],
    codes: NDArray[np.intp],
    order: NDArray[np.intp] | None,
) -> ComplexArray:
    """Roots in output order: ``out[order[i], m] = (re + i im)[table[codes[i], m], i]``.

    ``codes`` is piecewise constant (it changes only at flagged steps), so few segments are
    copied row slice by row slice; many segments fall back to fancy indexing. The result has
    shape ``(N, 4)`` and is the transpose of a C-ordered ``(4, N)`` array.
    """
    n = re.shape[1]
    out = np.empty((4, n), dtype=complex)
    edges = np.flatnonzero(codes[1:] != codes[:-1]) + 1
    if edges.size >= _MAX_SEGMENTS:
        index = table[codes].T
        out.real = np.take_along_axis(re, index, axis=0)
        out.imag = np.take_along_axis(im, index, axis=0)
    else:
        for lo, hi in itertools.pairwise([0, *edges.tolist(), n]):
            for m, row in enumerate(table[codes[lo]]):
                out.real[m, lo:hi] = re[row, lo:hi]
                out.imag[m, lo:hi] = im[row, lo:hi]
    if order is not None:
        unsorted = np.empty_like(out)
        unsorted[:, order] = out
        out = unsorted
    return out.T


def eigenvalues(matrices: WhippleMatrices, g: float, speeds: ArrayLike, vectors: bool = False) -> EigenvalueSweep:
    """Eigenvalues (1/s) of the Whipple model at many speeds, tracked and labelled.

    All speeds are solved at once by closed-form quartic roots of
    ``det(M s² + v C1 s + g K0 + v² K2)`` (no per-speed ``eig``). The roots are then tracked
    across the sorted speeds: columns are kept where that is provably the best matching and
    the minimum summed-distance permutation is used at the other steps; step permutations are
    composed by a log-doubling prefix scan. Each speed's factorisation is checked against the
    quartic's coefficients and, where it fails (rare, badly scaled cases), recomputed from a
    companion matrix. Errors are ~1e-13 · |s| for well-separated roots (benchmark speeds:
    < 1e-13 1/s) and grow like the square root of machine precision at double roots
    (branch points), as for any eigenvalue method.

    Labels come from the structure at the *highest* speed (see :func:`_label_order`) and are
    carried back along the tracks, so a column keeps its label at every speed: at the
    benchmark's low speeds the two "weave" columns are the two real unstable roots that merge
    into the weave pair, "capsize" and "caster" the two stable real roots. If the capsize and
    caster roots become a complex pair over some speed interval, the "capsize" and "caster"
    columns hold the two conjugate members there (which member is which is decided by the
    minimum-distance continuation at the branch point; both describe one oscillatory mode).
    The same holds for the weave columns below the weave branch point (real there).

    Args:
        matrices: Canonical matrices of one bicycle (shape ``(2, 2)`` each, real).
        g: Gravity (m/s²).
        speeds: Speeds (m/s), any order, scalar or 1-D; results keep the caller's order.
            Tracking is along increasing speed, so it is only meaningful where neighbouring
            speeds are close.
        vectors: Also compute state-space eigenvectors.

    Returns:
        The sweep, columns ordered as :data:`MODE_LABELS`.

    Raises:
        ModelError: Matrices not of one real bicycle, singular ``M``, or bad speeds.
    """
    _scalar_matrices(matrices)
    v = _speed_array(speeds)
    order = None if np.all(v[1:] >= v[:-1]) else np.argsort(v, kind="stable")
    v_sorted = v if order is None else v[order]
    coef = np.asarray(characteristic_polynomial(matrices, float(g)).coefficients, dtype=float)
    re, im, steps = _sorted_roots(coef, v_sorted)
    codes = _track(re, im, steps)
    top = _PERMS[codes[-1]]
    labels = _label_order(re[top, -1] + 1j * im[top, -1])
    values = _gather(re, im, _PERMS[:, labels], codes, order)
    vecs = _eigenvectors(matrices, float(g), v, values) if vectors else None
    return EigenvalueSweep(speeds=v, eigenvalues=values, labels=MODE_LABELS, eigenvectors=vecs)


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
    _scalar_matrices(matrices)
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
        d3 * a2 * a1 + a3 * d2 * a1 + a3 * a2 * d1
        - d4 * a1 * a1 - 2.0 * a4 * a1 * d1 - d0 * a3 * a3 - 2.0 * a0 * a3 * d3
    )  # fmt: skip
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
    """``d Re s/dv`` of a pair ``s = ±iω`` on the imaginary axis: ``Re(-(∂p/∂v)/(∂p/∂s))`` at
    ``s = iω`` (implicit function theorem on ``p(s, v) = Σ a_k(v) s^k``); 1/m.

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


def stable_speed_range(
    matrices: WhippleMatrices, g: float, v_max: float = math.inf
) -> tuple[tuple[float, float], ...]:
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
