"""What a trial's fit found beyond its period, as the fitter publishes it (``FitDetails``).

The ``PeriodEstimate`` carries what the parameters need (the period, σ, flags); the fit also
tells how the swing decays, whether the period follows the swing, and how it moves along the
record (:mod:`bike_rig.core.period.damping`, :mod:`bike_rig.core.period.stationarity`). Those
travel in a ``FitDetails`` message of their own, so that recordings made before them keep
their ``PeriodEstimate`` definition; the parameter node, the replay and the console join the two
by trial id (:func:`join_details`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace

from ..core.period import PeriodFit
from .fit import TrialFit

__all__ = ["FitDetails", "join_details"]


@dataclass(frozen=True)
class FitDetails:
    """A trial's fit beyond its period (:class:`~bike_rig.core.period.PeriodFit`'s fields of the same names).

    Attributes:
        trial_id: The trial.
        stamp_ns: As its estimate's (rig time of the STOP), ns.
        damping_model: ``viscous``, ``dry`` or ``combined``.
        friction: The dry-friction decay rate, 1/s.
        friction_sigma: Its σ, 1/s.
        swing_kappa: The period's dependence on the swing (0: none).
        centre_period: The period at the window centre's swing, s (NaN: no swing term).
        small_swing_period: The period of a vanishing swing, s (NaN: no swing term).
        small_swing_period_sigma: Its σ, s.
        window_periods: The period along the record, s.
        window_period_sigmas: Their σ, s.
        notes: The fit's remarks.
        ends_period: The record's own mean period from the phase at the window's ends, s (NaN:
            fewer than 6 cycles, or a recording made before this field).
        ends_period_sigma: Its σ, s.
        small_swing_systematic: The small-swing period's systematic σ, included in the
            estimate's ``period_sigma``, s (0: none; NaN: not evaluated, the option off, or a
            recording made before this field).
    """

    trial_id: str
    stamp_ns: int = 0
    damping_model: str = "viscous"
    friction: float = 0.0
    friction_sigma: float = math.nan
    swing_kappa: float = 0.0
    centre_period: float = math.nan
    small_swing_period: float = math.nan
    small_swing_period_sigma: float = math.nan
    window_periods: tuple[float, ...] = ()
    window_period_sigmas: tuple[float, ...] = ()
    notes: tuple[str, ...] = ()
    ends_period: float = math.nan
    ends_period_sigma: float = math.nan
    small_swing_systematic: float = math.nan

    @classmethod
    def of(cls, trial: TrialFit) -> FitDetails:
        """The details of a trial's fit."""
        return cls(trial.trial_id, trial.stamp_ns, **{name: getattr(trial.fit, name) for name in _OF_THE_FIT})

    def apply(self, trial: TrialFit) -> TrialFit:
        """``trial`` (e.g. read from its ``PeriodEstimate``) with these details in its fit."""
        fit: PeriodFit = replace(trial.fit, **{name: getattr(self, name) for name in _OF_THE_FIT})
        return replace(trial, fit=fit)

    def summary(self, period: float) -> str:
        """What an operator should see, in a few words ("" when the fit is plain Eq 23 and steady).

        Args:
            period: The trial's reported period, s (to say how far the windows move).
        """
        parts = []
        if self.damping_model != "viscous":
            parts.append(f"damping {self.damping_model}")
        if math.isfinite(self.small_swing_period):
            parts.append(f"small-swing T₀ {self.small_swing_period:.6g} ± {self.small_swing_period_sigma:.2g} s")
        moves = any("moves beyond its σ" in n for n in self.notes)
        if moves and self.window_periods and math.isfinite(period) and period > 0:
            spread = (max(self.window_periods) - min(self.window_periods)) / period
            parts.append(
                f"period moves {self.window_periods[0]:.5g} → {self.window_periods[-1]:.5g} s ({100 * spread:.2g} %)"
            )
        return ", ".join(parts)


def join_details(trial: TrialFit, details: Mapping[str, FitDetails]) -> TrialFit:
    """``trial`` with the fit details held for its trial id joined (as is when none arrived).

    The details and the estimate travel on topics of their own, either may come first: a
    listener keeps the newest details by trial id and joins them to every estimate of the trial.

    Args:
        trial: A period estimate.
        details: The newest details received, by trial id.
    """
    found = details.get(trial.trial_id)
    return trial if found is None else found.apply(trial)


#: The fields that are the fit's own (:class:`~bike_rig.core.period.PeriodFit`'s of the same names).
_OF_THE_FIT = tuple(f.name for f in fields(FitDetails) if f.name not in ("trial_id", "stamp_ns"))
