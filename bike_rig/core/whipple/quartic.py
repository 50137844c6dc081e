"""Closed-form roots of real quartics, vectorised (Ferrari with a real resolvent root).

:func:`quartic_roots` solves ``a4 s⁴ + a3 s³ + a2 s² + a1 s + a0 = 0`` for many quartics at
once (no iteration over elements); :func:`quartic_into` writes the roots of monic
quartics into preallocated ``(4, N)`` arrays and is what the eigenvalue sweep of
:mod:`bike_rig.core.whipple.modes` uses. Inputs and roots are in whatever unit ``s`` has
(1/s for the bicycle's characteristic polynomial).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ModelError

__all__ = ["quartic_into", "quartic_roots"]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]


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
    quartic_into(b, c, d, e, re, im)
    return re, im


def quartic_into(b: FloatArray, c: FloatArray, d: FloatArray, e: FloatArray, re: FloatArray, im: FloatArray) -> None:
    """:func:`_monic_quartic_parts` writing into given ``(4, N)`` arrays (or views).

    Args:
        b: ``a3/a4`` of each monic quartic ``s⁴ + b s³ + c s² + d s + e``, shape ``(N,)``
            (units of ``s``).
        c: ``a2/a4`` (units of ``s²``).
        d: ``a1/a4`` (units of ``s³``).
        e: ``a0/a4`` (units of ``s⁴``).
        re: Output real parts, shape ``(4, N)``, in factor order (see :func:`_monic_quartic_parts`).
        im: Output imaginary parts, same shape.
    """
    with np.errstate(all="ignore"):
        suspect = _ferrari(b, c, d, e, re, im)
    if suspect.size:
        re[:, suspect], im[:, suspect] = _companion_parts(b[suspect], c[suspect], d[suspect], e[suspect])


def _ferrari(
    b: FloatArray, c: FloatArray, d: FloatArray, e: FloatArray, re: FloatArray, im: FloatArray
) -> NDArray[np.intp]:
    """Body of :func:`quartic_into`; returns the columns that fail the factor check."""
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
    ``~1e-8 · scale`` at double roots. Not backward stable where one root is about 1e3 times or
    more the other three (coefficients spread over many decades): there the small roots can be
    off by up to ``~1e-6 · scale`` (test/core/test_quartic.py marks this as a known limit);
    the bicycles' quartics are far from that.

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
    this restores backward stability for most general quartics (not where one root is ~1e3
    times the other three, see :func:`quartic_roots`). The speed sweep does not need it
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
