"""The segment model chosen between Eq 23 and Eq 23 with a real mode, and the rider's drive.

The models are nested (:mod:`.realmode`: Eq 23 5 parameters, with a trend 6, with a real mode
7); all three are fitted from the same start (the trend's fit starts the real mode's and gives
the estimate of the rider's drive, :mod:`.noise`, for whichever model is reported). ``auto``
keeps Eq 23 or the real mode (:data:`AUTO_CANDIDATES`; on simulated rides with the rider's
steering, a trend chosen beside them scattered its segments 2.8 times their σ: it cannot follow
a capsize mode that decays within the segment), the one with the lowest small-sample quasi-AIC,

    QAICc = SSE / (ĉ s²) + 2p + 2p(p + 1) / (n_eff − p − 1),

with s² the largest model's residual variance and ĉ = n / n_eff its noise model's variance
inflation (:mod:`.noise`: correlated residuals are worth fewer samples, so a refinement must
lower the SSE by more to count). A refinement is kept only where it is significantly better
(Akaike weights ``w ∝ exp(−ΔQAICc/2)``), and never where it makes a record that Eq 23 finds
decaying unstable by more than their combined σ: then it is left out and a note says so. (The
other way is allowed: a fast capsize mode decaying under a slow weave makes Eq 23 see growth
that the real mode removes, e.g. the Browser with rider and balance assist at 5 m/s, weave
−0.009 + 2.35i: Eq 23 +0.047 ± 0.003, the real mode −0.012 ± 0.005 1/s.) The σ of the chosen
model is widened by the models' disagreement, ``σ² = σ_c² + Σ w_i (x_i − x_c)²`` (Burnham and
Anderson's unconditional variance about the chosen estimate). Units: 1/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .noise import pooled_drive
from .realmode import RealModeFit, RealModeFitFailed, fit_with_real_mode

__all__ = ["AUTO_CANDIDATES", "ModelChoice", "choose_model"]

#: The models ``auto`` chooses among (the trend starts the real mode's fit and estimates the drive).
AUTO_CANDIDATES = ("eq23", "eq23_real")

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class ModelChoice:
    """The chosen fit and its eigenvalue with σ widened by the models' disagreement.

    Attributes:
        fit: The chosen model's fit.
        real: Re λ = −α [1/s].
        real_sigma: Its σ, widened [1/s].
        imag: Im λ = ω_d [rad/s].
        imag_sigma: Its σ, widened [rad/s].
        notes: What was chosen and why, where it was not the only model.
        variance: ``(Re fixed, Re per unit drive, Im fixed, Im per unit drive)``: the chosen fit's
            :attr:`~.realmode.RealModeFit.variance` with the models' spread in the fixed parts.
        drive: The rider's drive q̂ (:mod:`.noise`), estimated from the real-mode fit whatever the
            model (the capsize mode left in Eq 23's residuals is no drive) [signal units² / s].
        drive_sigma: Its σ.
    """

    fit: RealModeFit
    real: float
    real_sigma: float
    imag: float
    imag_sigma: float
    notes: tuple[str, ...] = ()
    variance: tuple[float, float, float, float] = (math.nan, math.nan, math.nan, math.nan)
    drive: float = math.nan
    drive_sigma: float = math.nan


def _sigmas(fit: RealModeFit, q: float) -> tuple[float, float]:
    """σ of α and ω_d [1/s] at the drive ``q`` (:attr:`~.realmode.RealModeFit.variance`)."""
    v = fit.variance
    if not all(math.isfinite(x) for x in v):
        return fit.alpha_sigma, fit.omega_d_sigma
    return math.sqrt(max(0.0, v[0] + q * v[1])), math.sqrt(max(0.0, v[2] + q * v[3]))


def _choice(
    fit: RealModeFit, drive: RealModeFit, notes: tuple[str, ...] = (), re_spread: float = 0.0, im_spread: float = 0.0
) -> ModelChoice:
    """The choice of ``fit`` with ``drive``'s estimate of the drive, its σ widened by the models' spread [1/s²]."""
    v = fit.variance
    variance = (v[0] + re_spread, v[1], v[2] + im_spread, v[3])
    a_sigma, w_sigma = _sigmas(fit, pooled_drive([(drive.drive, drive.drive_sigma)]))
    return ModelChoice(
        fit,
        -fit.alpha,
        math.sqrt(a_sigma**2 + re_spread),
        fit.omega_d,
        math.sqrt(w_sigma**2 + im_spread),
        notes,
        variance,
        drive.drive,
        drive.drive_sigma,
    )


def _qaicc(fit: RealModeFit, scale: float, n_eff: float) -> float:
    p = fit.n_params
    return fit.sse / scale + 2.0 * p + 2.0 * p * (p + 1) / max(1.0, n_eff - p - 1.0)


def _destabilises(fit: RealModeFit, eq23: RealModeFit, q: float) -> bool:
    """The fit makes Eq 23's decaying weave grow (Re λ = −α), by more than their combined σ at the drive q."""
    return eq23.alpha > 0 > fit.alpha and eq23.alpha - fit.alpha > math.hypot(_sigmas(fit, q)[0], _sigmas(eq23, q)[0])


def choose_model(t: FloatArray, y: FloatArray, alpha0: float, omega_d0: float, model: str, white: float) -> ModelChoice:
    """The segment's fit by ``model`` (``auto``: chosen as the module docstring says).

    Args:
        t: Sample times [s].
        y: The samples.
        alpha0: Starting ζω [1/s].
        omega_d0: Starting ω_d [rad/s].
        model: ``auto``, ``eq23``, ``eq23_trend`` or ``eq23_real``.
        white: The sensor's white-noise σ [signal units].

    Raises:
        RealModeFitFailed: The model (``auto``: Eq 23) cannot be fitted.
    """
    eq23 = fit_with_real_mode(t, y, alpha0, omega_d0, trend=False, white=white)
    named = {"eq23": eq23}
    try:
        named["eq23_trend"] = fit_with_real_mode(t, y, alpha0, omega_d0, white=white)
        trend = named["eq23_trend"]
        named["eq23_real"] = fit_with_real_mode(t, y, trend.alpha, trend.omega_d, free_mu=True, white=white)
    except RealModeFitFailed:
        if model in ("eq23_trend", "eq23_real"):
            raise
    drive = named.get("eq23_trend", eq23)  # the drive seen past the slow modes
    if model != "auto":
        return _choice(named[model], drive)
    q = pooled_drive([(drive.drive, drive.drive_sigma)])
    fits = [f for name, f in named.items() if name in AUTO_CANDIDATES]
    largest = fits[-1]
    n_eff = largest.noise.n_eff(t.size)
    scale = largest.noise.inflation * largest.sse / max(1, t.size - largest.n_params)
    notes = []
    kept = []
    for f in fits:
        if f is not eq23 and not (math.isfinite(f.alpha_sigma) and math.isfinite(f.omega_d_sigma)):
            continue
        if f is not eq23 and _destabilises(f, eq23, q):
            notes.append(
                f"{f.model} left out: Re λ {-f.alpha:+.3f} ± {_sigmas(f, q)[0]:.3f} against Eq 23's "
                f"{-eq23.alpha:+.3f} ± {_sigmas(eq23, q)[0]:.3f} 1/s"
            )
            continue
        kept.append(f)
    if not scale > 0:  # a noise-free record: the most complete model
        return _choice(kept[-1], drive, tuple(notes))
    score = np.array([_qaicc(f, scale, n_eff) for f in kept])
    weights = np.exp(-0.5 * (score - score.min()))
    weights /= weights.sum()
    c = kept[int(np.argmin(score))]
    re_spread = float(np.sum(weights * np.square([f.alpha - c.alpha for f in kept])))
    im_spread = float(np.sum(weights * np.square([f.omega_d - c.omega_d for f in kept])))
    if len(kept) > 1:
        shares = ", ".join(f"{f.model} {w:.2f}" for f, w in zip(kept, weights, strict=True))
        notes.append(f"auto: {c.model} (Akaike weights {shares}; n_eff {n_eff:.0f} of {t.size} samples)")
    return _choice(c, drive, tuple(notes), re_spread, im_spread)
