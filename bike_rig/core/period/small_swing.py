"""The small-swing period's systematic: does the finite-swing law give the same period from other windows?

With the option ``small_swing_period`` a trial reports the period of a vanishing swing, 2π /
(ω (1 − κ)) (:mod:`~bike_rig.core.period.damping`): the finite-swing law extrapolated from the
swings the record holds to none. Its σ from the fit holds only if the law does; a law that is
only approximately right (an envelope model, a swing dependence that is not ∝ θ², a period
that moves for another reason) gives a small-swing period that depends on the window.

The check refits the trial in two trimmed windows, the window without its first and without
its last ``TRIM`` (each still spanning most of the swing's range, so that the law is
determined), and compares each one's small-swing period T₀ᵢ ± σᵢ with the whole window's T₀ ± σ.
The whole window's samples include the trimmed window's, so when the law holds their difference
dᵢ has the variance vᵢ = σᵢ² − σ² (the larger window's estimate is the more precise). Where
dᵢ² > vᵢ (the data then estimate a window dependence above zero), the small-swing period has a
systematic σ_sys² = dᵢ² + vᵢ (the largest over the trimmed windows): the window dependence as
the trimmed window estimates it, with its uncertainty. The reported σ is then
sqrt(σ² + σ_sys²) and the budget shows σ_sys as a line of its own.

A trimmed window whose fit does not keep the swing term (too little change of swing in it)
cannot be compared; when neither can, a note says that the systematic was not evaluated.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import replace

from .combine import common_systematic
from .result import PeriodFit
from .window import WindowPolicy

__all__ = ["SMALL_SWING_SOURCE", "TRIM", "small_swing_parts", "trimmed_windows", "with_small_swing_systematic"]

#: The share of the window each trimmed window leaves out, at its start or at its end.
TRIM = 0.25
#: The uncertainty budget's name of the small-swing period's systematic.
SMALL_SWING_SOURCE = "small-swing period: the swing law's window dependence"


def small_swing_parts(trials: Iterable[tuple[str, PeriodFit]]) -> dict[str, dict[str, float]]:
    """The small-swing systematic of each period key's combined period, for the budget's ``sigma_parts``, s.

    Args:
        trials: (period key, fit) of the trials that entered the combined periods.

    Returns:
        ``{SMALL_SWING_SOURCE: {key: σ_sys}}`` (:func:`~bike_rig.core.period.combine.common_systematic`),
        or {} when no key has one.
    """
    by_key: dict[str, list[PeriodFit]] = {}
    for key, fit in trials:
        by_key.setdefault(key, []).append(fit)
    parts = {key: common_systematic(fits) for key, fits in by_key.items()}
    parts = {key: value for key, value in parts.items() if value > 0}
    return {SMALL_SWING_SOURCE: parts} if parts else {}


def trimmed_windows(start_s: float, stop_s: float) -> tuple[WindowPolicy, WindowPolicy]:
    """The window ``[start_s, stop_s)`` [s from the first sample] without its first and without its last ``TRIM``."""
    cut = TRIM * (stop_s - start_s)
    return WindowPolicy.span(start_s + cut, stop_s), WindowPolicy.span(start_s, stop_s - cut)


def with_small_swing_systematic(
    fit: PeriodFit, span: tuple[float, float], refit: Callable[[WindowPolicy], PeriodFit]
) -> PeriodFit:
    """``fit`` (reporting the small-swing period) with its systematic from trimmed windows (module docstring).

    Args:
        fit: The whole window's fit with the option ``small_swing_period``.
        span: Its window, (start, stop) [s from the first sample].
        refit: Fits the same samples in another window (without the option).

    Returns:
        ``fit`` with ``small_swing_systematic`` (0 when the windows agree, NaN when not
        evaluated), ``small_swing_windows`` the trimmed windows' (T₀, σ) pairs, ``period_sigma``
        widened and a note.
    """
    if not (fit.valid and math.isfinite(fit.small_swing_period) and fit.period == fit.small_swing_period):
        return fit
    t0, sigma = fit.small_swing_period, fit.small_swing_period_sigma
    found: list[float] = []
    systematic = math.nan
    names = ("without its first quarter", "without its last quarter")
    worst = ""
    for name, policy in zip(names, trimmed_windows(*span), strict=True):
        other = refit(policy)
        if not (other.valid and math.isfinite(other.small_swing_period)):
            continue
        found += [other.small_swing_period, other.small_swing_period_sigma]
        d = other.small_swing_period - t0
        v = max(0.0, other.small_swing_period_sigma**2 - sigma**2)
        here = math.sqrt(d * d + v) if d * d > v else 0.0
        if math.isnan(systematic) or here > systematic:
            systematic = here
            worst = f"{name}: {other.small_swing_period:.6g} ± {other.small_swing_period_sigma:.2g} s"
    if math.isnan(systematic):
        note = (
            "the small-swing period's window dependence was not evaluated: the trimmed windows do not "
            "determine the swing law (too little change of swing in them)"
        )
        return replace(fit, small_swing_systematic=math.nan, notes=(*fit.notes, note))
    if systematic > 0:
        total = math.hypot(fit.period_sigma, systematic)
        note = (
            f"the small-swing period depends on the window ({worst}; the whole window's {t0:.6g} ± {sigma:.2g} s): "
            f"systematic σ {systematic:.2g} s, σ {total:.2g} s in all"
        )
    else:
        total = fit.period_sigma
        note = "the small-swing period agrees over trimmed windows within their σ (no systematic)"
    return replace(
        fit,
        period_sigma=total,
        small_swing_systematic=systematic,
        small_swing_windows=tuple(found),
        notes=(*fit.notes, note),
    )
