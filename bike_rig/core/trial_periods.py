"""Periods from raw trial files.

A measurement file may give a period as the trials it was measured in, ``{trials: [t1.npy,
t2.npy, t3.npy]}``; each is fitted (Eq 23–27) and the fits are combined into one period with σ.

A trial whose fit is invalid or flagged is kept in the record (with its reasons) and left out
of the combination; if no trial is usable the reading is an error that names the trials.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["PeriodEvidence", "period_from_trials"]


@dataclass(frozen=True)
class PeriodEvidence:
    """How one period reading was obtained from raw trials.

    Attributes:
        files: The trial files, as resolved paths.
        fits: One ``PeriodFit`` per file (see :mod:`bike_rig.core.period`).
        combined: The ``CombinedPeriod`` of the usable fits.
        trials: The samples read from each file (a :class:`bike_rig.core.trials.Trial` each),
            for plots of the fits.
    """

    files: tuple[str, ...]
    fits: tuple[Any, ...]
    combined: Any
    trials: tuple[Any, ...] = ()

    @property
    def value(self) -> float:
        """The combined period, s."""
        return float(self.combined.value)

    @property
    def sigma(self) -> float:
        """Its standard deviation, s."""
        return float(self.combined.sigma)


def period_from_trials(files: Sequence[Path], sample_rate_hz: float | None = None) -> PeriodEvidence:
    """Fit every trial file and combine the fits.

    Args:
        files: Trial files (.npy, .csv, BicycleParameters .mat).
        sample_rate_hz: Sample rate for files that carry no time stamps, Hz.

    Raises:
        InputFileError: a trial file cannot be read.
    """
    from .period import combine_periods, fit_period
    from .trials import read_trial

    fits = []
    trials = []
    for f in files:
        trial = read_trial(f, sample_rate_hz=sample_rate_hz)
        trials.append(trial)
        fits.append(fit_period(trial.samples, **trial.timing))
    combined = combine_periods(fits)
    return PeriodEvidence(tuple(str(f) for f in files), tuple(fits), combined, tuple(trials))
