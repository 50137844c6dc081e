"""The finite swing's systematic alternative: what the periods would be with the other choice.

A compound pendulum's period follows its swing (:mod:`bike_rig.core.period.damping`): the fit
gives the mean period over the window (the default) and that of a vanishing swing, and the
option ``small_swing_period`` says which one feeds the parameters. The other choice is a systematic
alternative of the analysis, not a random error: the uncertainty budget shows how far each
output would move under it (:func:`bike_rig.core.uncertainty.budget.uncertainty_budget`'s
``systematic``), so a lab sees when the swing's size, not the gyro's noise, limits its results.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .offline import SessionTrial

__all__ = ["swing_alternative"]

#: The alternatives' names, by the choice made.
TO_SMALL = "finite swing: the small-swing periods instead of the mean"
TO_FITTED = "finite swing: the mean periods instead of the small-swing"


def swing_alternative(trials: Sequence[SessionTrial]) -> dict[str, dict[str, float]]:
    """Per period key, the mean change of the used trials' periods under the other choice, s.

    Args:
        trials: The session's trials (those that entered a combined period count).

    Returns:
        ``{alternative: {period key: ΔT}}``, or {} when no used trial's period follows its
        swing.
    """
    shifts: dict[str, list[float]] = {}
    small_chosen = False
    for t in trials:
        fit = t.result.fit
        if not (t.used and math.isfinite(fit.small_swing_period) and math.isfinite(fit.mean_period)):
            continue
        if fit.period == fit.small_swing_period and fit.period != fit.mean_period:
            small_chosen = True
            delta = fit.mean_period - fit.small_swing_period
        else:
            delta = fit.small_swing_period - fit.mean_period
        shifts.setdefault(t.key, []).append(delta)
    if not shifts:
        return {}
    return {TO_FITTED if small_chosen else TO_SMALL: {k: float(np.mean(v)) for k, v in shifts.items()}}
