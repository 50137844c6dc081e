"""The model's weave eigenvalue at measured speeds: continuous or sampled assist, and its gain-scale derivative.

:func:`model_weave` gives, at each speed, the eigenvalue of the closed loop ``A − B s K`` (open
loop without feedback; ``s`` a scale on the feedback's gains) that oscillates and lies nearest a
target (the measured eigenvalue), for one bicycle or many at once. A digital assist that holds
its torque over each sample is modelled exactly (zero-order hold of the open loop, then
``log(eig(A_d − b_d K)) / Δt``), as :mod:`.ridesim` simulates it. :func:`scale_gradient` is
``∂λ/∂s`` of the continuous closed loop (complex step and the implicit function theorem).
Units: SI; eigenvalues 1/s; speeds m/s; gain scale dimensionless.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from ..feedback import Feedback
from ..uncertainty.uncertain import COMPLEX_STEP
from ..whipple import canonical_matrices, state_space
from ..whipple.closed_loop import closed_loop_rows, closed_loop_state_space
from ..whipple.sampled import sampled_closed_loop_eigenvalues

__all__ = ["MIN_IMAG", "model_weave", "scale_gradient"]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: An eigenvalue with a smaller imaginary part [1/s] is real.
MIN_IMAG = 1e-9


def _pick(lam: ComplexArray, near: ComplexArray) -> tuple[ComplexArray, NDArray[np.bool_], FloatArray]:
    """Per row: the oscillatory eigenvalue (Im > 0) nearest ``near`` (else the nearest), whether it oscillates.

    Also its distance to the nearest other eigenvalue, its conjugate included [1/s].
    """
    osc = lam.imag > MIN_IMAG
    dist = np.abs(lam - near[..., None])
    score = np.where(osc, dist, np.inf)
    any_osc = osc.any(axis=-1)
    j = np.where(any_osc, np.argmin(score, axis=-1), np.argmin(dist, axis=-1))
    picked = np.take_along_axis(lam, j[..., None], axis=-1)[..., 0]
    sep = np.abs(lam - picked[..., None])
    sep[np.arange(sep.shape[-1]) == j[..., None]] = np.inf
    return np.asarray(picked), np.asarray(any_osc), np.asarray(sep.min(axis=-1))


def model_weave(
    values: Mapping[str, object],
    speeds: FloatArray,
    feedback: Feedback | None,
    scale: float | FloatArray,
    near: ComplexArray,
    rate_hz: float | None = None,
) -> tuple[ComplexArray, NDArray[np.bool_], FloatArray]:
    """The model's weave eigenvalue nearest ``near`` at ``speeds`` [m/s] (module docstring).

    With ``rate_hz`` the assist is digital: its torque computed from each sample's state and held
    to the next (zero-order hold of the open loop, ``A_d = e^{A Δt}``); the eigenvalue is then
    ``log(eig(A_d − b_d K)) / Δt`` [1/s], as :mod:`.ridesim` simulates it.

    Args:
        values: The 26 parameters (floats, or arrays of shape (D,) for D bicycles at once).
        speeds: Shape (N,).
        feedback: The feedback, or None (open loop).
        scale: The gain scale (a float or shape (D,)).
        near: Target eigenvalues, shape (N,).
        rate_hz: The assist's sample rate [Hz] (None: continuous).

    Returns:
        Eigenvalues (…, N) [1/s], whether each oscillates, and its separation from the nearest
        other eigenvalue [1/s]; ``…`` is (D,) for arrays of values.

    Raises:
        ModelError: A singular mass matrix.
    """
    mats = canonical_matrices(values)  # type: ignore[arg-type]
    batch = np.ndim(mats.M) > 2
    g = np.asarray(values["g"], dtype=float)
    v = speeds if not batch else speeds[None, :]
    if batch:
        mats = type(mats)(*(x[:, None] for x in (mats.M, mats.C1, mats.K0, mats.K2)))
        g = g[:, None, None, None]
    if feedback is None:
        a, _ = state_space(mats, v, g)
        lam = np.linalg.eigvals(np.asarray(a, dtype=float)).astype(complex)
        return _pick(lam, np.broadcast_to(near, lam.shape[:-1]))
    s = np.asarray(scale, dtype=float)
    gains = feedback.gains(speeds) * (s[:, None, None] if batch and s.ndim else s)
    if rate_hz is None:
        a, _ = closed_loop_state_space(mats, v, g, gains)
        lam = np.linalg.eigvals(np.asarray(a, dtype=float)).astype(complex)
    else:
        lam = sampled_closed_loop_eigenvalues(mats, v, g, gains, 1.0 / rate_hz)
    return _pick(lam, np.broadcast_to(near, lam.shape[:-1]))


def scale_gradient(
    values: Mapping[str, float], speeds: FloatArray, lam: ComplexArray, feedback: Feedback, scale: float
) -> ComplexArray:
    """``∂λ/∂s`` of the closed-loop eigenvalues ``lam`` (N,) in the gain scale: complex step, implicit function."""
    k = feedback.gains(speeds)
    rows, _ = closed_loop_rows(canonical_matrices(values), values["g"], speeds, scale * k + 1j * COMPLEX_STEP * k)
    a = np.stack(np.broadcast_arrays(*rows), axis=-1)  # (N, 5) complex
    powers = np.arange(5)
    dp_dlam = np.sum(a.real[:, 1:] * powers[1:] * lam[:, None] ** (powers[1:] - 1), axis=-1)
    dp_ds = np.sum(a.imag / COMPLEX_STEP * lam[:, None] ** powers, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(-dp_ds / dp_dlam)
