"""Results of the period fitter: one trial's fit, its quality flags, and a combined period."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .window import DEFAULT_WINDOW, WindowPolicy

__all__ = ["TRIAL_FLAG_CODES", "CombinedPeriod", "Flag", "FlagCode", "PeriodFit"]


class FlagCode(str, Enum):
    """Why a trial should be redone (or why it has no period at all)."""

    #: No samples, or none left in the window.
    EMPTY = "empty"
    #: NaN or infinite samples (or timestamps) were found and left out.
    NON_FINITE = "non_finite"
    #: Timestamps that do not increase.
    BAD_TIMES = "bad_times"
    #: The samples do not change.
    CONSTANT = "constant"
    #: No oscillation stands out of the noise.
    NO_OSCILLATION = "no_oscillation"
    #: The least-squares fit did not converge to a usable oscillation.
    FIT_FAILED = "fit_failed"
    #: Fewer cycles in the window than asked for (a period needs at least 2).
    TOO_FEW_CYCLES = "too_few_cycles"
    #: r² below the threshold.
    POOR_FIT = "poor_fit"
    #: Envelope or phase modulation: a second, close mode (paper Fig. 7, Eq 24).
    BEATING = "beating"
    #: Runs of samples stuck at the record's extreme values (ADC saturation).
    CLIPPED = "clipped"
    #: Runs of repeated values where the signal must have moved (held / gap-filled samples).
    GAP_FILLED = "gap_filled"
    #: The slow drift of the offset is large against the oscillation.
    DRIFT = "drift"
    #: The period moves along the record beyond its model (constant, or following the swing)
    #: by a multiple of its σ.
    PERIOD_DRIFT = "period_drift"

    # Trial-level codes: how the trial's samples were received (set by the fitting stage,
    # :mod:`bike_rig.pipeline.fit`, before the fit's own flags).
    #: Gyro batches of a trial never announced (no START, no STOP).
    UNKNOWN_TRIAL = "unknown_trial"
    #: A STOP without a START: what the trial measured is unknown.
    NO_START = "no_start"
    #: The trial never stopped: fitted as far as it was received.
    NO_STOP = "no_stop"
    #: The trial was aborted.
    ABORTED = "aborted"
    #: Batches larger than the limit were rejected.
    OVERSIZED_BATCH = "oversized_batch"
    #: Samples beyond the per-trial limit were dropped.
    TRUNCATED = "truncated"
    #: Samples of batches overlapping earlier ones were dropped.
    OVERLAP = "overlap"
    #: Samples are missing.
    GAP = "gap"
    #: More samples arrived than the driver announced.
    SAMPLE_COUNT = "sample_count"
    #: The batches' (or the START event's) sample rates disagree.
    RATE_MISMATCH = "rate_mismatch"
    #: No usable sample rate: nothing was fitted.
    BAD_RATE = "bad_rate"


#: The trial-level codes, which come before a fit's own flags.
TRIAL_FLAG_CODES: frozenset[FlagCode] = frozenset(
    {
        FlagCode.UNKNOWN_TRIAL,
        FlagCode.NO_START,
        FlagCode.NO_STOP,
        FlagCode.ABORTED,
        FlagCode.OVERSIZED_BATCH,
        FlagCode.TRUNCATED,
        FlagCode.OVERLAP,
        FlagCode.GAP,
        FlagCode.SAMPLE_COUNT,
        FlagCode.RATE_MISMATCH,
        FlagCode.BAD_RATE,
    }
)


@dataclass(frozen=True)
class Flag:
    """A quality flag: its code and a reason a person can act on."""

    code: FlagCode
    reason: str

    def __str__(self) -> str:
        """The flag as ``<code>: <reason>``."""
        return f"{self.code.value}: {self.reason}"


@dataclass(frozen=True)
class PeriodFit:
    """The fit of Eq 23 to one trial.

    Times are on the trial's own time axis (the given ``times``, or ``index / sample_rate``).
    A, B, C, ζ, ω are Eq 23's parameters with t measured from ``t_ref``, the first sample of
    the window. Values that could not be determined are NaN.

    Attributes:
        period: The mean period over the window [s]: T = 2π / (ω sqrt(1 − ζ²)) (Eq 25), the
            window's length over its cycles also when the period follows the swing (unless
            the option ``small_swing_period`` reports that of a vanishing swing).
        period_sigma: Its standard uncertainty [s], honest for serially correlated residuals
            (see :mod:`bike_rig.core.period.fit`) and widened by ``sigma_widening`` when the
            period moves along the record beyond what the fit's model explains.
        zeta: Damping ratio ζ [-].
        omega: Undamped natural angular frequency ω [rad/s].
        A: Offset [sample units].
        B: Sine amplitude at ``t_ref`` [sample units].
        C: Cosine amplitude at ``t_ref`` [sample units].
        r2: Coefficient of determination of the fit in the window [-].
        residual_rms: Root mean square of the residuals [sample units].
        n_cycles: Oscillation cycles in the window [-].
        n_samples: Samples used by the fit.
        window: (start, stop) indices into the input samples, stop exclusive.
        valid: Whether a period was determined at all.
        flags: Quality problems; a flagged trial should be redone.
        window_policy: The window rule used.
        t_ref: Time of t = 0 in Eq 23 [s].
        period_sigma_white: σ_T from Eq 26–27 as printed (assumes white residuals) [s].
        zeta_sigma: Standard uncertainty of ζ [-].
        omega_sigma: Standard uncertainty of ω [rad/s].
        alpha_sigma: Standard uncertainty of the decay rate ζω [1/s] (the same sandwich as
            ``period_sigma``; the eigenvalue −ζω ± iω sqrt(1 − ζ²) has σ ``alpha_sigma`` and
            2π ``period_sigma`` / ``period``² on its parts).
        sigma_dof: Effective degrees of freedom of the σ estimate [-].
        modulation: Largest smooth relative envelope/phase deviation from Eq 23 over the
            window (the beating statistic) [-].
        drift: Peak-to-peak slow drift of the residuals over the peak-to-peak oscillation [-].
        notes: Remarks that need no action (e.g. timestamp gaps handled).
        damping_model: How the swing decays, the model the data support
            (:mod:`~bike_rig.core.period.damping`): ``viscous`` (Eq 23), ``dry`` (a linear
            envelope: dry friction at the pivot) or ``combined``.
        friction: The envelope's linear fall per second (dry friction), relative to the
            amplitude at ``damping_origin`` [1/s]; 0 for ``viscous``.
        friction_sigma: Its standard uncertainty [1/s].
        damping_origin: The time the damping model's envelope is referred to (the window's
            centre) [s]; NaN for Eq 23.
        swing_kappa: The period's dependence on the swing (a compound pendulum's finite
            swing): the frequency is ω (1 + κ (E² − 1)) with E the envelope relative to the
            swing at ``damping_origin`` (0: not fitted; ``period`` is the period there) [-].
        small_swing_period: The period of a vanishing swing 2π / (ω_d (1 − κ)) [s]; NaN when
            the period does not follow the swing.
        small_swing_period_sigma: Its standard uncertainty [s].
        centre_period: The period at the swing of the window's centre, 2π / ω_d [s]; NaN when
            the period does not follow the swing.
        mean_period: The mean period over the window [s] (``period`` unless the option
            ``small_swing_period`` reports the small-swing one).
        sigma_widening: ``period_sigma`` over the model's own σ (1: the windowed periods
            follow the fit's model within their σ; else the Birge ratio and the model's
            departure from the windows' mean period, or the windows' own σ when the model's law
            is rejected; ``small_swing_period_sigma`` is multiplied by the Birge ratio, see
            :mod:`~bike_rig.core.period.stationarity`) [-].
        window_periods: The periods of consecutive windows of whole cycles, in record order
            (:mod:`~bike_rig.core.period.stationarity`; empty for fewer than 8 cycles) [s].
        window_period_sigmas: Their standard uncertainties [s].
        ends_period: The record's own mean period from its phase at the window's two ends,
            free of any period law (:mod:`~bike_rig.core.period.ends`; NaN for fewer than 6
            cycles) [s].
        ends_period_sigma: Its standard uncertainty [s].
        small_swing_systematic: The small-swing period's systematic σ (the finite-swing law's
            extrapolation), when the option ``small_swing_period`` is used: how far trimmed
            windows' small-swing periods depart beyond their σ (0: they agree; NaN: not
            evaluated), included in ``period_sigma`` (:mod:`~bike_rig.core.period.small_swing`) [s].
        small_swing_windows: The trimmed windows' small-swing periods and σ, (T₀, σ, ...) [s].
    """

    period: float
    period_sigma: float
    zeta: float
    omega: float
    A: float
    B: float
    C: float
    r2: float
    residual_rms: float
    n_cycles: float
    n_samples: int
    window: tuple[int, int]
    valid: bool
    flags: tuple[Flag, ...]
    window_policy: WindowPolicy = DEFAULT_WINDOW
    t_ref: float = 0.0
    period_sigma_white: float = math.nan
    zeta_sigma: float = math.nan
    omega_sigma: float = math.nan
    alpha_sigma: float = math.nan
    sigma_dof: float = math.nan
    modulation: float = math.nan
    drift: float = math.nan
    notes: tuple[str, ...] = field(default=())
    damping_model: str = "viscous"
    friction: float = 0.0
    friction_sigma: float = math.nan
    damping_origin: float = math.nan
    swing_kappa: float = 0.0
    small_swing_period: float = math.nan
    small_swing_period_sigma: float = math.nan
    centre_period: float = math.nan
    mean_period: float = math.nan
    sigma_widening: float = 1.0
    window_periods: tuple[float, ...] = ()
    window_period_sigmas: tuple[float, ...] = ()
    ends_period: float = math.nan
    ends_period_sigma: float = math.nan
    small_swing_systematic: float = math.nan
    small_swing_windows: tuple[float, ...] = ()

    @property
    def swing_amplitude(self) -> float:
        """The swing at the window's first sample, √(B² + C²)/ω_d [rad when the samples are rad/s].

        A rate gyro's amplitude over the angular frequency: the pendulum's angle amplitude, for
        a calibrated gyro (the rig's samples are rad/s; a trial file in volts gives V·s).
        """
        omega_d = self.omega * math.sqrt(max(0.0, 1.0 - self.zeta**2))
        return math.hypot(self.B, self.C) / omega_d if omega_d > 0 else math.nan

    @property
    def clean(self) -> bool:
        """Valid and without flags: usable in a combined period."""
        return self.valid and not self.flags

    @property
    def flag_codes(self) -> tuple[str, ...]:
        """The flags' codes, e.g. ``("beating",)``."""
        return tuple(f.code.value for f in self.flags)

    def has_flag(self, code: FlagCode) -> bool:
        """Whether ``code`` is among the flags."""
        return any(f.code is code for f in self.flags)

    def predict(self, t: ArrayLike) -> NDArray[np.float64]:
        """Eq 23 with the fitted parameters at times ``t`` on the trial's time axis [s]."""
        from .oscillation import damped_oscillation

        tt = np.asarray(t, dtype=float) - self.t_ref
        if not self.valid:
            return np.full(tt.shape, math.nan)
        if self.damping_model == "viscous":
            return damped_oscillation(tt, self.A, self.B, self.C, self.zeta, self.omega)
        from .damping import envelope
        from .damping_fit import swing_phase

        omega_d = self.omega * math.sqrt(1.0 - self.zeta**2)
        alpha = self.zeta * self.omega
        shift = self.t_ref - self.damping_origin
        tau = np.atleast_1d(tt).ravel() + shift
        extra = swing_phase(omega_d, self.swing_kappa, np.append(tau, shift), alpha, self.friction)
        extra = extra[:-1] - extra[-1]  # from t_ref
        start = math.atan2(-self.B, self.C)  # the phase at t_ref
        steps = (omega_d, extra + (start - omega_d * shift))
        e, _, _ = envelope(tau, alpha, self.friction, steps)
        e0, _, _ = envelope(np.array([shift]), alpha, self.friction, (omega_d, start - omega_d * shift))
        phase = omega_d * tt + extra.reshape(np.shape(tt))
        osc = self.B * np.sin(phase) + self.C * np.cos(phase)
        return np.asarray(self.A + (e / e0[0]).reshape(np.shape(tt)) * osc, dtype=np.float64)

    @classmethod
    def invalid(
        cls,
        flags: tuple[Flag, ...],
        window_policy: WindowPolicy,
        window: tuple[int, int] = (0, 0),
        n_samples: int = 0,
        notes: tuple[str, ...] = (),
    ) -> PeriodFit:
        """A result without a period, explained by ``flags``."""
        nan = math.nan
        return cls(
            period=nan,
            period_sigma=nan,
            zeta=nan,
            omega=nan,
            A=nan,
            B=nan,
            C=nan,
            r2=nan,
            residual_rms=nan,
            n_cycles=nan,
            n_samples=n_samples,
            window=window,
            valid=False,
            flags=flags,
            window_policy=window_policy,
            notes=notes,
        )


@dataclass(frozen=True)
class CombinedPeriod:
    """Several trials of one period measurement, combined (weighted mean).

    Attributes:
        value: Weighted mean period of the trials used [s] (NaN if none).
        sigma: Its standard uncertainty [s]: the internal σ, multiplied by the Birge ratio when
            the trials scatter more than their σ say.
        n_used: Trials in the mean.
        n_flagged: Valid trials left out because of quality flags.
        n_invalid: Trials without a period.
        chi2: Σ ((T_i − value) / σ_i)² of the trials used.
        dof: ``n_used − 1``.
        birge_ratio: sqrt(chi2 / dof) (NaN for a single trial).
        sigma_internal: 1 / sqrt(Σ 1/σ_i²) [s] (σ_i without the shared systematic).
        notes: What was left out and why, and whether σ was inflated.
        systematic: The systematic σ part the trials share, included in ``sigma`` whole (the
            small-swing period's; 0 when none) [s].
    """

    value: float
    sigma: float
    n_used: int
    n_flagged: int
    n_invalid: int
    chi2: float
    dof: int
    birge_ratio: float
    sigma_internal: float
    notes: tuple[str, ...]
    systematic: float = 0.0
