"""Frequency response of the Whipple model at a constant speed (paper Figs 17–18).

``G(s) = (M s² + v C1 s + g K0 + v² K2)⁻¹`` at ``s = iω`` (angles ``[φ, δ]`` per torque
``[Tφ, Tδ]``, rad/(N m)); rates are ``s G(s)`` (rad/s per N m). Steer-torque state feedback adds
``[kφ + kφ̇ s, kδ + kδ̇ s]`` to the steer row (the closed loop ``A − B K``, input the torque added
to the controller's). The 2 × 2 inverse is written out, vectorised over frequencies; checked
against :func:`scipy.signal.freqresp` in ``test/core/test_frequency.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import ModelError
from .whipple import WhippleMatrices

__all__ = ["INPUTS", "OUTPUTS", "Bode", "bode", "frequency_response", "output_unit"]

#: Inputs of the model: generalised torques about the roll and steer axes (N m).
INPUTS = ("roll torque", "steer torque")
#: Outputs: the angles (rad) and their rates (rad/s).
OUTPUTS = ("roll angle", "steer angle", "roll rate", "steer rate")

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]


@dataclass(frozen=True)
class Bode:
    """A Bode diagram of one input → output pair.

    Attributes:
        omega: Angular frequencies, rad/s.
        magnitude_db: ``20 log10 |G(iω)|``, dB relative to 1 output unit per N m.
        phase_deg: ``arg G(iω)``, degrees, unwrapped along ω.
        input: The input (one of :data:`INPUTS`).
        output: The output (one of :data:`OUTPUTS`).
        speed: Forward speed, m/s.
    """

    omega: FloatArray
    magnitude_db: FloatArray
    phase_deg: FloatArray
    input: str
    output: str
    speed: float


def output_unit(output: str) -> str:
    """The unit of an output per unit input: ``rad/(N m)`` or ``rad/(s N m)``."""
    return "rad/(s N m)" if output.endswith("rate") else "rad/(N m)"


def _index(name: str, allowed: tuple[str, ...], what: str) -> int:
    try:
        return allowed.index(name)
    except ValueError:
        raise ModelError(f"unknown {what} '{name}': expected one of {', '.join(allowed)}") from None


def frequency_response(
    matrices: WhippleMatrices,
    g: float,
    speed: float,
    omega: ArrayLike,
    input: str = "steer torque",
    output: str = "roll angle",
    gains: ArrayLike | None = None,
) -> ComplexArray:
    """``G(iω)`` of one input → output pair at one speed.

    Args:
        matrices: Canonical matrices of one bicycle (2 × 2 each).
        g: Gravity, m/s².
        speed: Forward speed ``v``, m/s.
        omega: Angular frequencies ``ω`` ≥ 0, rad/s.
        input: One of :data:`INPUTS`.
        output: One of :data:`OUTPUTS`.
        gains: Steer-torque feedback ``[kφ, kδ, kφ̇, kδ̇]`` at ``speed`` (N m/rad, N m s/rad):
            the closed loop's response; None: the open loop.

    Returns:
        Complex array shaped like ``omega``, in :func:`output_unit` of ``output``.

    Raises:
        ModelError: Unknown input or output, a non-finite speed or frequency.
    """
    col = _index(input, INPUTS, "input")
    row = _index(output, OUTPUTS, "output")
    w = np.asarray(omega, dtype=float)
    if not (np.isfinite(speed) and np.all(np.isfinite(w))):
        raise ModelError("speed and frequencies must be finite numbers")
    s = 1j * w
    v = float(speed)
    m, c1, k0, k2 = (np.asarray(x, dtype=float) for x in (matrices.M, matrices.C1, matrices.K0, matrices.K2))
    ss = s[..., None, None]
    d = m * ss**2 + v * c1 * ss + (g * k0 + v**2 * k2)  # shape omega.shape + (2, 2)
    if gains is not None:
        k = np.asarray(gains, dtype=float).reshape(4)
        d[..., 1, 0] += k[0] + k[2] * s
        d[..., 1, 1] += k[1] + k[3] * s
    det = d[..., 0, 0] * d[..., 1, 1] - d[..., 0, 1] * d[..., 1, 0]
    # inverse of [[a, b], [c, e]] is [[e, -b], [-c, a]] / det
    adj = {(0, 0): d[..., 1, 1], (0, 1): -d[..., 0, 1], (1, 0): -d[..., 1, 0], (1, 1): d[..., 0, 0]}
    angle = adj[(row % 2, col)] / det
    return np.asarray(angle * s if row >= 2 else angle)


def bode(
    matrices: WhippleMatrices,
    g: float,
    speed: float,
    omega: ArrayLike,
    input: str = "steer torque",
    output: str = "roll angle",
    gains: ArrayLike | None = None,
) -> Bode:
    """Magnitude (dB) and unwrapped phase (degrees) of :func:`frequency_response` (closed loop with ``gains``)."""
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    resp = frequency_response(matrices, g, speed, w, input, output, gains)
    with np.errstate(divide="ignore"):
        mag = 20.0 * np.log10(np.abs(resp))
    phase = np.degrees(np.unwrap(np.angle(resp)))
    return Bode(w, mag, phase, input, output, float(speed))
