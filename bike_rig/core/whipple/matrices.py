"""Canonical matrices of the linearised Whipple bicycle (Meijaard et al. 2007, Appendix A).

``M q̈ + v C1 q̇ + (g K0 + v² K2) q = f``, ``q = [φ, δ]`` (rad), ``f = [T_φ, T_δ]`` (N m).
:func:`canonical_matrices` (from the 26 parameters; broadcasting, complex-step safe),
:func:`state_space` (``ẋ = A x + B f``, ``x = [φ, δ, φ̇, δ̇]``),
:func:`characteristic_polynomial` / :func:`characteristic_coefficients`
(``det(M s² + v C1 s + g K0 + v² K2)`` in ``s`` and ``v``). SI: m, kg, kg m², rad, m/s², m/s.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ModelError
from ..symbols import PARAMETER_NAMES as PARAMETER_KEYS

__all__ = [
    "PARAMETER_KEYS",
    "CharacteristicPolynomial",
    "WhippleMatrices",
    "canonical_matrices",
    "characteristic_coefficients",
    "characteristic_polynomial",
    "check_one_bicycle",
    "state_space",
]

Array = NDArray[Any]


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
        p["IRxx"]
        + p["IBxx"]
        + p["IHxx"]
        + p["IFxx"]
        + p["mR"] * p["rR"] ** 2
        + p["mB"] * p["zB"] ** 2
        + p["mH"] * p["zH"] ** 2
        + p["mF"] * p["rF"] ** 2
    )
    i_txz = (
        p["IBxz"] + p["IHxz"] - p["mB"] * p["xB"] * p["zB"] - p["mH"] * p["xH"] * p["zH"] + p["mF"] * p["w"] * p["rF"]
    )
    i_tzz = (
        i_rzz + p["IBzz"] + p["IHzz"] + i_fzz + p["mB"] * p["xB"] ** 2 + p["mH"] * p["xH"] ** 2 + p["mF"] * p["w"] ** 2
    )
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
    i_axz = p["IHxz"] - p["mH"] * (p["xH"] - x_a) * (p["zH"] - z_a) + p["mF"] * (p["w"] - x_a) * (p["rF"] + z_a)
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
        a[..., 0, 0] * b[..., 1, 1]
        + b[..., 0, 0] * a[..., 1, 1]
        - a[..., 0, 1] * b[..., 1, 0]
        - b[..., 0, 1] * a[..., 1, 0]
    )


def _inverse2(a: Array) -> Array:
    """Closed-form inverse of ``(..., 2, 2)`` arrays."""
    adj = np.stack(
        [np.stack([a[..., 1, 1], -a[..., 0, 1]], -1), np.stack([-a[..., 1, 0], a[..., 0, 0]], -1)],
        axis=-2,
    )
    return adj / _det2(a)[..., None, None]


def check_one_bicycle(matrices: WhippleMatrices) -> None:
    """Check that the matrices describe one real bicycle (each one real, finite 2x2 matrix).

    Args:
        matrices: Canonical matrices (``M`` in kg m², ``C1`` in kg m, ``K0`` in kg m, ``K2`` in kg).

    Raises:
        ModelError: A matrix is not one real, finite 2x2 matrix, or ``M`` is singular.
    """
    for name in ("M", "C1", "K0", "K2"):
        mat = np.asarray(getattr(matrices, name))
        if mat.shape != (2, 2) or np.iscomplexobj(mat) or not np.all(np.isfinite(mat)):
            raise ModelError(f"{name} must be one real, finite 2x2 matrix, got shape {mat.shape}")
    if _det2(np.asarray(matrices.M)) == 0:
        raise ModelError("the mass matrix M is singular")


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
