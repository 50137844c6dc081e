"""Several trials of one period measurement combined into the value ± σ the science core uses.

The paper repeats each period measurement three times and averages. Here the valid, unflagged
trials are averaged with weights ``1/σ_i²``; the internal σ is ``1/sqrt(Σ 1/σ_i²)``. When the
trials disagree by more than their σ allow (``chi2 > dof``), σ is multiplied by the Birge ratio
``sqrt(chi2/dof)``, so the between-trial scatter (a different swing amplitude, a slightly
different hanging) is part of σ. Flagged and invalid trials are left out, counted and named in
the notes: the operator should redo them. A systematic σ part the trials share (the small-swing
period's, :mod:`~bike_rig.core.period.small_swing`) is taken out of each trial's σ before the
mean and added back whole (``systematic``): averaging trials does not reduce it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .result import CombinedPeriod, PeriodFit

__all__ = ["combine_periods", "common_systematic", "weighted_mean"]


def combine_periods(fits: Sequence[PeriodFit], include_flagged: bool = False) -> CombinedPeriod:
    """Weighted mean of the usable trials' periods, with the Birge ratio folded into σ.

    Args:
        fits: The trials' fits.
        include_flagged: Also use valid trials that carry quality flags.

    Returns:
        The combined period; ``value`` and ``sigma`` are NaN when no trial is usable.
    """
    notes: list[str] = []
    used: list[PeriodFit] = []
    n_flagged = n_invalid = 0
    for i, fit in enumerate(fits, start=1):
        if not fit.valid:
            n_invalid += 1
            reasons = "; ".join(str(f) for f in fit.flags) or "no period"
            notes.append(f"trial {i} has no period ({reasons})")
        elif not (math.isfinite(fit.period_sigma) and fit.period_sigma > 0):
            n_invalid += 1
            notes.append(f"trial {i} left out: its σ is {fit.period_sigma}")
        elif fit.flags and not include_flagged:
            n_flagged += 1
            notes.append(f"trial {i} left out, redo it: " + "; ".join(str(f) for f in fit.flags))
        else:
            used.append(fit)
    if not used:
        notes.append("no usable trial")
        nan = math.nan
        return CombinedPeriod(nan, nan, 0, n_flagged, n_invalid, nan, 0, nan, nan, tuple(notes))
    systematic = common_systematic(used)
    own = [_own_sigma(f) for f in used]
    value, sigma, sigma_internal, chi2, birge = weighted_mean([f.period for f in used], own)
    if systematic > 0:  # (shared by the trials: it does not average down)
        sigma = math.hypot(sigma, systematic)
        notes.append(f"the small-swing period's systematic σ {systematic:.2g} s is shared by the trials: added whole")
    dof = len(used) - 1
    if dof > 0 and birge > 1.0:
        notes.append(f"the trials scatter more than their σ (Birge ratio {birge:.2f}); σ inflated by it")
    if len(used) == 1:
        notes.append("a single usable trial: σ is its fit σ, the between-trial scatter is unknown")
    return CombinedPeriod(
        value=value,
        sigma=sigma,
        n_used=len(used),
        n_flagged=n_flagged,
        n_invalid=n_invalid,
        chi2=chi2,
        dof=dof,
        birge_ratio=birge,
        sigma_internal=sigma_internal,
        notes=tuple(notes),
        systematic=systematic,
    )


def _systematic(fit: PeriodFit) -> float:
    """The fit's systematic σ part (the small-swing period's), 0 when it has none, s."""
    value = fit.small_swing_systematic
    return value if math.isfinite(value) and fit.period == fit.small_swing_period else 0.0


def _own_sigma(fit: PeriodFit) -> float:
    """The fit's σ without its systematic part, s."""
    part = _systematic(fit)
    if part == 0.0:
        return fit.period_sigma
    return math.sqrt(max(fit.period_sigma**2 - part**2, 0.0)) or fit.period_sigma


def common_systematic(fits: Sequence[PeriodFit]) -> float:
    """The systematic σ the trials share: the mean of their small-swing systematics (0 when none has one), s.

    The finite-swing law's window dependence is the pendulum's, not the trial's: the trials'
    estimates of it are averaged, and the result is not divided down by the number of trials.
    """
    parts = [_systematic(f) for f in fits if math.isfinite(f.small_swing_systematic)]
    return float(np.mean(parts)) if parts else 0.0


def weighted_mean(values: Sequence[float], sigmas: Sequence[float]) -> tuple[float, float, float, float, float]:
    """Weighted mean x̄ = Σ (xᵢ/σᵢ²) / Σ (1/σᵢ²) and its σ, widened by the Birge ratio when the values scatter.

    Args:
        values: The values (any unit).
        sigmas: Their σ (> 0, same unit).

    Returns:
        (x̄, σ, σ_internal = 1/sqrt(Σ 1/σᵢ²), χ² = Σ ((xᵢ − x̄)/σᵢ)², Birge ratio sqrt(χ²/(n − 1)),
        NaN for one value); σ = σ_internal × the Birge ratio when it exceeds 1. A single value
        is returned as it is, bit for bit.
    """
    x = np.asarray(values, dtype=float)
    s = np.asarray(sigmas, dtype=float)
    weights = 1.0 / s**2
    if x.size == 1:  # the value itself, bit for bit (w x / w and 1/sqrt(1/σ²) round)
        value, sigma_internal = float(x[0]), float(s[0])
    else:
        value = float(np.sum(weights * x) / np.sum(weights))
        sigma_internal = float(1.0 / math.sqrt(float(np.sum(weights))))
    chi2 = float(np.sum(weights * (x - value) ** 2))
    birge = math.sqrt(chi2 / (x.size - 1)) if x.size > 1 else math.nan
    sigma = sigma_internal * birge if x.size > 1 and birge > 1.0 else sigma_internal
    return value, sigma, sigma_internal, chi2, birge
