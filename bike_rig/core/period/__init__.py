"""Pendulum periods from rate-gyro trials (paper section 9, Eq 23–27).

The rig measures every inertia through a pendulum period: a rate gyro on the hanging part,
sampled (at 1 kHz in the paper) for 15–30 s, three trials per orientation. This package fits
the paper's decaying oscillation (Eq 23) to each trial, reports the period (Eq 25) with an
honest σ and quality flags, and combines the trials of one measurement.

API::

    from bike_rig.core.period import fit_period, combine_periods, WindowPolicy

    fit = fit_period(samples, sample_rate_hz=1000.0)        # or times=array_of_seconds
    fit.period, fit.period_sigma, fit.valid, fit.flags      # s, s, bool, (Flag(code, reason), ...)
    fit_period(samples, times=t, window=WindowPolicy.span(2.0, 20.0), min_cycles=8)
    combined = combine_periods([fit1, fit2, fit3])          # .value ± .sigma [s], .n_used, .notes

``fit_period(samples, sample_rate_hz=None, times=None, *, window=DEFAULT_WINDOW,
min_cycles=4.0, min_r2=0.9, max_modulation=0.02, max_drift=0.5, min_valid_cycles=2.0) -> PeriodFit``

* exactly one of ``sample_rate_hz`` [Hz] and ``times`` [s] (uneven spacing and gaps are fine);
  otherwise ``ValueError``. Bad *data* never raise: empty, constant, pure noise, all-NaN, a
  single cycle... give ``valid=False`` with a flag that says why.
* :class:`PeriodFit`: ``period``, ``period_sigma`` [s]; Eq 23's ``zeta``, ``omega`` [rad/s],
  ``A``, ``B``, ``C`` (t from ``t_ref``); ``r2``, ``residual_rms``, ``n_cycles``,
  ``n_samples``, ``window`` (start, stop sample indices used, stop exclusive),
  ``window_policy``, ``valid``, ``flags``; also ``period_sigma_white`` (Eq 27 as printed),
  ``zeta_sigma``, ``omega_sigma``, ``alpha_sigma`` (σ of ζω), ``sigma_dof``, ``modulation``, ``drift``, ``notes``;
  ``predict(t)``; ``clean`` (valid and unflagged).
* ``period`` is the mean period over the window (Eq 25; with a finite swing, the window's
  length over its cycles); its σ covers the period's movement along the record beyond the
  fit's model (``sigma_widening``, :mod:`.stationarity`) and beyond the record's own phase at
  the window's ends (``ends_period``, free of any period law: :mod:`.ends`). With
  ``small_swing_period=True`` it is the period of a vanishing swing, its σ including the
  finite-swing law's window dependence (``small_swing_systematic``, :mod:`.small_swing`).
* Flags (:class:`FlagCode`): ``too_few_cycles``, ``poor_fit``, ``beating``, ``clipped``,
  ``gap_filled``, ``non_finite``, ``drift``, ``period_drift``; and, without a period, ``empty``, ``constant``,
  ``no_oscillation``, ``fit_failed``, ``bad_times``. A flagged trial keeps its period but
  should be redone; :func:`combine_periods` leaves it out.

``combine_periods(fits, include_flagged=False) -> CombinedPeriod``: weighted mean of the
clean trials, σ inflated by the Birge ratio when they scatter more than their σ; ``value``,
``sigma`` (a systematic the trials share added whole: ``systematic``), ``n_used``, ``n_flagged``,
``n_invalid``, ``chi2``, ``dof``, ``birge_ratio``,
``sigma_internal``, ``notes``. Its ``value ± sigma`` is a ``Tc*``/``Tt*`` reading of the
measurement file.

``valid`` means an oscillation was found: its spectral peak stands out of the residuals' noise
floor with a false-alarm probability of at most 1e-4 per record of noise (white, quantised,
1/f, random walk), see :mod:`.detection`.

Modules: :mod:`.model` (Eq 23, 25, 26), :mod:`.window` (window policies), :mod:`.spectrum`
(initial guess), :mod:`.detection` (is there an oscillation?), :mod:`.fit` (the fit and its σ:
read its docstring for how σ is made honest),
:mod:`.quality` (flags), :mod:`.combine`, :mod:`.result` (the dataclasses).
"""

from __future__ import annotations

from .combine import combine_periods
from .fit import FitOptions, fit_period
from .oscillation import damped_oscillation, damped_period
from .result import TRIAL_FLAG_CODES, CombinedPeriod, Flag, FlagCode, PeriodFit
from .window import DEFAULT_WINDOW, WindowKind, WindowPolicy

__all__ = [
    "DEFAULT_WINDOW",
    "TRIAL_FLAG_CODES",
    "CombinedPeriod",
    "FitOptions",
    "Flag",
    "FlagCode",
    "PeriodFit",
    "WindowKind",
    "WindowPolicy",
    "combine_periods",
    "damped_oscillation",
    "damped_period",
    "fit_period",
]
