"""The Whipple model under a digital steer-torque feedback: state sampled, torque held one period.

A controller running at ``1/T`` Hz reads the state ``x = [φ, δ, φ̇, δ̇]`` at ``t = kT`` and holds
``T_δ = −K x(kT)`` until the next sample (zero-order hold). :func:`zero_order_hold` gives the
open loop's one-period map ``x[k+1] = Φ x[k] + Γ u[k]``; the loop is then
``x[k+1] = (Φ − Γ K) x[k]`` and :func:`sampled_closed_loop_eigenvalues` gives its eigenvalues as
continuous-time ``λ = ln z / T`` (1/s), comparable with :func:`.closed_loop.closed_loop_state_space`'s
and equal to them as ``T → 0``. Checked against ``scipy.signal.cont2discrete``, ``scipy.linalg.expm``
and a step-by-step integration of the held loop in ``test/core/test_sampled_loop.py``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ModelError
from .matrices import WhippleMatrices, state_space

__all__ = ["NYQUIST_SHARE", "aliased", "sampled_closed_loop_eigenvalues", "zero_order_hold"]

FloatArray = NDArray[np.float64]

#: A sampled mode with ``|Im λ|`` beyond this share of ``π/T`` is too fast for the controller's
#: rate: its ``ln z / T`` is no longer a trustworthy continuous-time eigenvalue [-].
NYQUIST_SHARE = 0.5

#: Terms of the Taylor series in :func:`_expm` (after scaling to :data:`_SCALED_NORM`) [-].
_TAYLOR_ORDER = 12
#: :func:`_expm` halves its argument until its ∞-norm is at most this [-].
_SCALED_NORM = 0.25


def _expm(x: FloatArray) -> FloatArray:
    """``e^x`` of a batch of small matrices ``(…, n, n)``: Taylor series with scaling and squaring.

    ``x`` is halved ``s`` times until ``θ = ‖x / 2^s‖_∞ ≤ 1/4`` (one ``s`` for the whole batch),
    the series summed to order 12 and squared back ``s`` times. The series' remainder is at most
    ``θ^13 / 13! · 1/(1 − θ/14) < 3e-18``, and ``‖e^{−y}‖ ≤ e^θ``, so it is below 4e-18 of
    ``e^y``: under the unit roundoff (1.1e-16), the standard ``scipy.linalg.expm``'s Padé step
    meets before the same squarings. ``scipy.linalg.expm`` works one matrix at a time; this is
    a few matrix products over the whole batch (the ride posterior's batches of draws).
    """
    norm = float(np.max(np.sum(np.abs(x), axis=-1))) if x.size else 0.0
    squarings = max(0, math.ceil(math.log2(norm / _SCALED_NORM))) if norm > _SCALED_NORM else 0
    y = x / 2.0**squarings
    term = np.broadcast_to(np.eye(x.shape[-1]), x.shape).copy()
    out = term.copy()
    for k in range(1, _TAYLOR_ORDER + 1):
        term = term @ y / k
        out += term
    for _ in range(squarings):
        out = out @ out
    return out


def zero_order_hold(a: ArrayLike, b: ArrayLike, period: float) -> tuple[FloatArray, FloatArray]:
    """The exact one-period map of ``ẋ = A x + B u`` with ``u`` held over ``T``: ``(Φ, Γ)``.

    ``exp([[A, B], [0, 0]] T) = [[Φ, Γ], [0, I]]`` with ``Φ = e^{A T}`` [-] and
    ``Γ = ∫₀ᵀ e^{A s} ds B`` (``B``'s units times s), so ``x[k+1] = Φ x[k] + Γ u[k]``.

    Args:
        a: ``A`` (…, n, n) [1/s and 1/s²] (e.g. :func:`.matrices.state_space`'s), a batch.
        b: ``B`` (…, n, m), broadcast against ``A``'s batch.
        period: ``T`` [s], finite and > 0.

    Returns:
        ``Φ`` of shape (…, n, n) and ``Γ`` of shape (…, n, m).

    Raises:
        ModelError: ``T`` not finite and > 0, ``A`` or ``B`` not finite, or ``e^{A T}`` beyond
            floating point.
    """
    if not (math.isfinite(period) and period > 0.0):
        raise ModelError(f"a sampled controller needs a finite period > 0 s, got {period!r}")
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    n, m = a.shape[-1], b.shape[-1]
    batch = np.broadcast_shapes(a.shape[:-2], b.shape[:-2])
    aug = np.zeros(batch + (n + m, n + m))
    aug[..., :n, :n] = a
    aug[..., :n, n:] = b
    if not np.all(np.isfinite(aug)):
        raise ModelError("the open loop's state-space matrices are not finite")
    with np.errstate(all="ignore"):
        e = _expm(aug * period)
    if not np.all(np.isfinite(e)):
        raise ModelError(f"the open loop grows beyond floating point over one controller period of {period:g} s")
    return e[..., :n, :n], e[..., :n, n:]


def sampled_closed_loop_eigenvalues(
    matrices: WhippleMatrices, v: ArrayLike, g: ArrayLike, gains: ArrayLike, period: float
) -> NDArray[np.complex128]:
    """Eigenvalues ``λ = ln z / T`` [1/s] of the loop whose steer torque ``−K x`` is sampled and held over ``T``.

    :func:`zero_order_hold` of the open loop ``ẋ = A x + b T_δ`` (``b`` the steer-torque column
    of :func:`.matrices.state_space`'s ``B``, 1/(kg m²)) gives ``Φ`` and ``Γ``; the sampled loop
    is ``x[k+1] = (Φ − Γ K) x[k]``; ``z = eig(Φ − Γ K)`` [-] and ``λ = ln z / T`` on the
    principal branch, ``|Im λ| ≤ π/T`` (a mode near ``π/T`` is too fast for the rate:
    :func:`aliased`). ``λ → eig(A − B K)`` as ``T → 0``.

    Args:
        matrices: Canonical matrices (one bicycle or a batch ``S``).
        v: Speed(s) [m/s].
        g: Gravity [m/s²].
        gains: ``[kφ, kδ, kφ̇, kδ̇]`` at ``v`` [N m/rad, N m s/rad], shape ``shape(v) + (4,)``.
        period: The controller's period ``T`` [s], finite and > 0.

    Returns:
        Shape ``broadcast(S, v) + (4,)`` [1/s], each row in :func:`numpy.linalg.eigvals` order.

    Raises:
        ModelError: ``T`` not finite and > 0, so long that ``e^{A T}`` overflows, or a singular
            mass matrix.
    """
    a, b = state_space(matrices, v, g)
    phi, gamma = zero_order_hold(a, np.asarray(b, dtype=float)[..., 1:], period)
    k = np.broadcast_to(np.asarray(gains, dtype=float), phi.shape[:-1])
    z = np.linalg.eigvals(phi - gamma * k[..., None, :]).astype(complex)
    with np.errstate(divide="ignore"):  # z = 0 (a dead-beat mode): λ = −inf
        return np.asarray(np.log(z) / period)


def aliased(lam: Any, period: float) -> NDArray[np.bool_]:
    """Whether each sampled eigenvalue ``lam`` [1/s] is too fast for the period ``T`` [s].

    True where ``|Im λ| > NYQUIST_SHARE · π/T`` or ``λ`` is not finite (``z = 0``).
    """
    x = np.asarray(lam, dtype=complex)
    return np.asarray(~np.isfinite(x) | (np.abs(x.imag) > NYQUIST_SHARE * math.pi / period))
