"""The Whipple model under a digital steer-torque feedback: state sampled, torque held one period.

A controller running at ``1/T`` Hz reads the state ``x = [φ, δ, φ̇, δ̇]`` at ``t = kT`` and holds
``T_δ = −K x(kT)`` until the next sample (zero-order hold). The loop is then the discrete map
``x[k+1] = (Φ − Γ K) x[k]``; :func:`sampled_closed_loop_eigenvalues` gives its eigenvalues as
continuous-time ``λ = ln z / T`` (1/s), comparable with :func:`.closed_loop.closed_loop_state_space`'s
and equal to them as ``T → 0``. Checked against ``scipy.signal.cont2discrete`` and a
step-by-step integration of the held loop in ``test/core/test_sampled_loop.py``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ModelError
from .matrices import WhippleMatrices, state_space

__all__ = ["NYQUIST_SHARE", "aliased", "sampled_closed_loop_eigenvalues"]

#: A sampled mode with ``|Im λ|`` beyond this share of ``π/T`` is too fast for the controller's
#: rate: its ``ln z / T`` is no longer a trustworthy continuous-time eigenvalue [-].
NYQUIST_SHARE = 0.5


def sampled_closed_loop_eigenvalues(
    matrices: WhippleMatrices, v: ArrayLike, g: ArrayLike, gains: ArrayLike, period: float
) -> NDArray[np.complex128]:
    """Eigenvalues ``λ = ln z / T`` [1/s] of the loop whose steer torque ``−K x`` is sampled and held over ``T``.

    Exact zero-order hold of the open loop ``ẋ = A x + b T_δ`` (``b`` the steer-torque column of
    :func:`.matrices.state_space`'s ``B``, 1/(kg m²)) over one period:
    ``exp([[A, b], [0, 0]] T) = [[Φ, Γ], [0, 1]]`` with ``Φ = e^{A T}`` [-] and
    ``Γ = ∫₀ᵀ e^{A s} ds b`` [s/(kg m²) and 1/(kg m²)]. The sampled loop is
    ``x[k+1] = (Φ − Γ K) x[k]``; ``z = eig(Φ − Γ K)`` [-] and ``λ = ln z / T`` on the principal
    branch, ``|Im λ| ≤ π/T`` (a mode near ``π/T`` is too fast for the rate: :func:`aliased`).
    ``λ → eig(A − B K)`` as ``T → 0``.

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
    from scipy.linalg import expm

    if not (math.isfinite(period) and period > 0.0):
        raise ModelError(f"a sampled controller needs a finite period > 0 s, got {period!r}")
    a, b = state_space(matrices, v, g)
    a = np.asarray(a, dtype=float)
    aug = np.zeros(a.shape[:-2] + (5, 5))
    aug[..., :4, :4] = a
    aug[..., :4, 4] = np.broadcast_to(np.asarray(b, dtype=float)[..., 1], a.shape[:-1])
    with np.errstate(all="ignore"):
        e = np.asarray(expm(aug * period), dtype=float)
    if not np.all(np.isfinite(e)):
        raise ModelError(f"the open loop grows beyond floating point over one controller period of {period:g} s")
    k = np.broadcast_to(np.asarray(gains, dtype=float), a.shape[:-1])
    z = np.linalg.eigvals(e[..., :4, :4] - e[..., :4, 4, None] * k[..., None, :]).astype(complex)
    with np.errstate(divide="ignore"):  # z = 0 (a dead-beat mode): λ = −inf
        return np.asarray(np.log(z) / period)


def aliased(lam: Any, period: float) -> NDArray[np.bool_]:
    """Whether each sampled eigenvalue ``lam`` [1/s] is too fast for the period ``T`` [s].

    True where ``|Im λ| > NYQUIST_SHARE · π/T`` or ``λ`` is not finite (``z = 0``).
    """
    x = np.asarray(lam, dtype=complex)
    return np.asarray(~np.isfinite(x) | (np.abs(x.imag) > NYQUIST_SHARE * math.pi / period))
