"""Eigenvalues of the Whipple model over many speeds, tracked and labelled by mode.

:func:`eigenvalues` gives the four eigenvalues (1/s) of ``M s² + v C1 s + g K0 + v² K2`` at many
speeds (m/s) at once, by the closed-form quartic roots of :mod:`bike_rig.core.whipple.quartic`,
tracks them across speeds and labels them weave / capsize / caster (:data:`MODE_LABELS`);
optionally with the state-space eigenvectors. The result is an :class:`EigenvalueSweep`.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ModelError
from .closed_loop import closed_loop_coefficients
from .matrices import WhippleMatrices, characteristic_polynomial, check_one_bicycle
from .quartic import quartic_into

__all__ = ["MODE_LABELS", "EigenvalueSweep", "eigenvalues"]

#: Labels of the eigenvalue columns returned by :func:`eigenvalues`, in column order.
MODE_LABELS: tuple[str, str, str, str] = ("weave", "weave", "capsize", "caster")

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
#: ``monic(lo, hi)``: monic quartic coefficients ``b, c, d, e`` of the sorted speeds ``lo:hi``.
MonicCoefficients = Callable[[int, int], tuple[FloatArray, FloatArray, FloatArray, FloatArray]]


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


def _eigenvector_block(
    entries: list[tuple[float, ...]], v: FloatArray, s: ComplexArray, gains: FloatArray | None = None
) -> ComplexArray:
    """Eigenvectors (see :func:`_eigenvectors`) for one block of speeds ``v`` and roots ``s``.

    ``gains`` (shape ``(n, 4)``, or None) add the feedback row ``[kφ + kφ̇ s, kδ + kδ̇ s]`` to
    the steer row of ``P(s)``.
    """
    vv = v[:, None]
    s2 = s * s
    mat = [m * s2 + (c1 * vv) * s + (k0 + k2 * vv * vv) for m, c1, k0, k2 in entries]
    p00, p01, p10, p11 = mat
    if gains is not None:
        p10 = p10 + gains[:, 0:1] + gains[:, 2:3] * s
        p11 = p11 + gains[:, 1:2] + gains[:, 3:4] * s
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


def _eigenvectors(
    matrices: WhippleMatrices, g: float, v: FloatArray, s: ComplexArray, gains: FloatArray | None = None
) -> ComplexArray:
    """State-space eigenvectors ``[q, s q]`` with ``(M s² + v C1 s + g K0 + v² K2) q = 0``.

    With ``gains`` (shape ``(N, 4)``) the steer row has the feedback added (closed loop).

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
        out[block] = _eigenvector_block(entries, v[block], s[block], None if gains is None else gains[block])
    return out


def _sorted_roots(
    coef: FloatArray, v: FloatArray, monic: MonicCoefficients | None = None
) -> tuple[FloatArray, FloatArray, NDArray[np.intp]]:
    """Quartic roots at the sorted speeds ``v``, block by block, and the flagged steps.

    ``monic(lo, hi)`` gives the monic coefficients of the speeds ``v[lo:hi]`` (default: the open
    loop's, from ``coef``).

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
        bcde = _monic_speed_coefficients(coef, v[lo:hi]) if monic is None else monic(lo, hi)
        quartic_into(*bcde, re[:, lo:hi], im[:, lo:hi])
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


def _closed_loop_monic(matrices: WhippleMatrices, g: float, v: FloatArray, gains: FloatArray) -> MonicCoefficients:
    """``monic(lo, hi)`` of the closed loop with ``gains[i]`` at the (sorted) speed ``v[i]``."""

    def monic(lo: int, hi: int) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        a = closed_loop_coefficients(matrices, g, v[lo:hi], gains[lo:hi])
        a = a / a[..., :1]
        return a[:, 1], a[:, 2], a[:, 3], a[:, 4]

    return monic


def _gain_array(gains: ArrayLike, n: int) -> FloatArray:
    """Gains as a finite ``(n, 4)`` float array (one row per speed, or one row for all)."""
    arr = np.asarray(gains, dtype=float)
    if arr.shape == (4,):
        arr = np.broadcast_to(arr, (n, 4))
    if arr.shape != (n, 4) or not np.all(np.isfinite(arr)):
        raise ModelError(f"feedback gains must be finite, shape (4,) or ({n}, 4), got shape {arr.shape}")
    return np.ascontiguousarray(arr)


def eigenvalues(
    matrices: WhippleMatrices, g: float, speeds: ArrayLike, vectors: bool = False, gains: ArrayLike | None = None
) -> EigenvalueSweep:
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
        gains: Steer-torque state feedback ``[kφ, kδ, kφ̇, kδ̇]`` (N m/rad, N m s/rad) at each
            speed, shape ``(N, 4)`` in the order of ``speeds`` (or ``(4,)`` for all): the
            eigenvalues are those of the closed loop ``A − B K``
            (:func:`.closed_loop.closed_loop_coefficients`). None: the open loop.

    Returns:
        The sweep, columns ordered as :data:`MODE_LABELS`.

    Raises:
        ModelError: Matrices not of one real bicycle, singular ``M``, or bad speeds.
    """
    check_one_bicycle(matrices)
    v = _speed_array(speeds)
    order = None if np.all(v[1:] >= v[:-1]) else np.argsort(v, kind="stable")
    v_sorted = v if order is None else v[order]
    coef = np.asarray(characteristic_polynomial(matrices, float(g)).coefficients, dtype=float)
    k = None if gains is None else _gain_array(gains, v.size)
    k_sorted = k if k is None or order is None else k[order]
    monic = None if k_sorted is None else _closed_loop_monic(matrices, float(g), v_sorted, k_sorted)
    re, im, steps = _sorted_roots(coef, v_sorted, monic)
    codes = _track(re, im, steps)
    top = _PERMS[codes[-1]]
    labels = _label_order(re[top, -1] + 1j * im[top, -1])
    values = _gather(re, im, _PERMS[:, labels], codes, order)
    vecs = _eigenvectors(matrices, float(g), v, values, k) if vectors else None
    return EigenvalueSweep(speeds=v, eigenvalues=values, labels=MODE_LABELS, eigenvectors=vecs)
