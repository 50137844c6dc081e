"""A trial's fit under the damping model its data support: period, σ, statistics and flags.

:func:`apply_damping` turns Eq 23's fit (:mod:`~bike_rig.core.period.fit`) into the fit of the
model :func:`~bike_rig.core.period.damping.select_damping` chose: the period and its σ, ζ, ω,
Eq 23's A, B, C at the window's first sample, the dry-friction rate, r² and the residual RMS
from every sample's residual, and the flags that depend on the model (a poor fit, beating).
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .damping import TRY_FROM, DampingChoice, EnvelopeFit, envelope, select_damping, swing_integral
from .oscillation import TWO_PI, zeta_omega
from .quality import Modulation, modulation_index, steady_phase, two_mode_flag
from .result import Flag, FlagCode, PeriodFit
from .sigma import BlockDesign
from .solver import FitFailed, Solution
from .stationarity import PhaseResidual

if TYPE_CHECKING:
    from .fit import FitOptions

__all__ = ["apply_damping", "fit_damping", "phase_residual", "swing_phase", "with_small_swing_period"]

FloatArray = NDArray[np.float64]


def swing_phase(env_omega: float, kappa: float, tau: FloatArray, alpha: float, gamma: float) -> FloatArray:
    """The finite swing's extra phase ω κ I(τ) at times ``tau`` from the origin, rad (0 without κ)."""
    if kappa == 0.0:
        return np.zeros_like(tau)
    return np.asarray((env_omega * kappa) * swing_integral(tau, alpha, gamma), dtype=np.float64)


def _model(env: EnvelopeFit, tau: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The envelope and the oscillation ``E(τ)``, ``Re(P e^(i(ωτ + ω κ I(τ))))`` at ``tau``."""
    extra = swing_phase(env.omega, env.kappa, tau, env.alpha, env.gamma)
    e, _, _ = envelope(tau, env.alpha, env.gamma, (env.omega, extra + cmath.phase(env.P)))
    return e, (env.P * np.exp(1j * (env.omega * tau + extra))).real


def _residuals(
    env: EnvelopeFit, y: FloatArray, tau: FloatArray, units: tuple[float, float]
) -> tuple[FloatArray, float]:
    """Every sample's residual from the envelope model with a constant offset, and that offset.

    The fit's piecewise linear offset only keeps the drift out of the envelope parameters;
    the residuals, r² and the drawn curve (:meth:`PeriodFit.predict`) use one constant offset,
    the samples' mean residual, as Eq 23 does, so that the two models compare fairly.

    Returns:
        The residuals (samples' units) and the offset A (scaled units).
    """
    scale, offset = units
    e, osc = _model(env, tau)
    r = y - (offset + scale * (e * osc))
    constant = float(np.mean(r))
    r -= constant
    return r, constant / scale


def apply_damping(
    fit: PeriodFit,
    choice: DampingChoice,
    env: EnvelopeFit,
    y: FloatArray,
    tau: FloatArray,
    units: tuple[float, float],
    caller: tuple[float, float],
    viscous: Modulation,
    options: FitOptions,
) -> PeriodFit:
    """``fit`` (Eq 23's) redone under the chosen damping model ``env``.

    Args:
        fit: Eq 23's fit of the trial.
        choice: The model chosen and why.
        env: The chosen model's fit (scaled units, τ from the window centre).
        y: The window's samples, in ``units``.
        tau: Their times from the window centre, s.
        units: (scale, offset) from the fit's scaled units to those of ``y``.
        caller: (scale, offset) from the fit's scaled units to the caller's samples.
        viscous: Eq 23's beating statistics.
        options: The fit's options (thresholds).

    Returns:
        The fit under ``env``'s model. Beating is flagged only when the envelope/phase
        modulation stands out of both models' fits: an envelope the model explains (a linear
        fall) is no second mode.
    """
    scale_units = units[0]
    r, offset_a = _residuals(env, y, tau, units)
    sse = float(np.einsum("i,i->", r, r))
    centred = y - float(np.mean(y))
    sst = float(np.einsum("i,i->", centred, centred))
    r2 = 1.0 - sse / sst if sst > 0 else math.nan
    zeta, omega = zeta_omega(env.alpha, env.omega)
    tau0 = float(tau[0])
    extra0 = float(swing_phase(env.omega, env.kappa, tau, env.alpha, env.gamma)[0])  # (the window's grid)
    e0, _, _ = envelope(np.array([tau0]), env.alpha, env.gamma, (env.omega, extra0 + cmath.phase(env.P)))
    norm = float(e0[0])  # B, C: the amplitude at the first sample
    K_ref = env.P * norm * cmath.exp(1j * (env.omega * tau0 + extra0))
    caller_scale, caller_offset = caller
    swinging = env.amplitude > 0.1 * float(np.max(env.amplitude))  # (the cycles before a stop)
    modulation = modulation_index(steady_phase(env.deviation[swinging]), env.amplitude[swinging])
    flags = [f for f in fit.flags if f.code not in (FlagCode.BEATING, FlagCode.POOR_FIT)]
    beating = two_mode_flag(viscous, modulation, options.max_modulation)
    if beating is not None:
        flags.append(beating)
    if not r2 >= options.min_r2:
        flags.append(
            Flag(FlagCode.POOR_FIT, f"r² = {r2:.3f} < {options.min_r2:g}: no damping model describes the record")
        )
    out = replace(
        fit,
        period=env.mean_period,
        period_sigma=env.sigma_mean_period,
        zeta=zeta,
        omega=omega,
        A=offset_a * caller_scale + caller_offset,
        B=float(-K_ref.imag) * caller_scale,
        C=float(K_ref.real) * caller_scale,
        r2=r2,
        residual_rms=math.sqrt(sse / y.size) / scale_units * caller_scale,
        zeta_sigma=env.sigma_alpha / env.omega if math.isfinite(env.sigma_alpha) else 0.0,
        omega_sigma=env.sigma_omega,
        alpha_sigma=env.sigma_alpha if math.isfinite(env.sigma_alpha) else 0.0,
        sigma_dof=env.dof,
        modulation=modulation.depth,
        flags=tuple(flags),
        notes=(*fit.notes, choice.describe()),
        damping_model=env.model.value,
        friction=env.gamma,
        friction_sigma=env.sigma_gamma,
        damping_origin=fit.t_ref - tau0,
        swing_kappa=env.kappa,
        small_swing_period=env.small_swing_period if env.swing else math.nan,
        small_swing_period_sigma=env.sigma_small_swing_period,
        centre_period=env.period if env.swing else math.nan,
        mean_period=env.mean_period,
    )
    return out


def with_small_swing_period(fit: PeriodFit) -> PeriodFit:
    """``fit`` reporting the small-swing period as ``period`` (option ``small_swing_period``), when it has one."""
    if not math.isfinite(fit.small_swing_period):
        return fit
    note = "the small-swing period is reported (option small_swing_period)"
    return replace(
        fit, period=fit.small_swing_period, period_sigma=fit.small_swing_period_sigma, notes=(*fit.notes, note)
    )


def phase_residual(env: EnvelopeFit) -> PhaseResidual:
    """The chosen model's per-cycle departures, with its swing term's phase per unit κ (rad)."""
    if not env.swing:
        return PhaseResidual(env.deviation, env.amplitude, env.omega)
    centres = env.span[0] + (np.arange(env.deviation.size, dtype=np.float64) + 0.5) * (TWO_PI / env.omega)
    shape = env.omega * swing_integral(centres, env.alpha, env.gamma)
    return PhaseResidual(env.deviation, env.amplitude, env.omega, "the swing", shape)


def fit_damping(
    fit: PeriodFit,
    blocks: BlockDesign,
    viscous_fit: Solution,
    samples: tuple[FloatArray, Callable[[], FloatArray]],
    units: tuple[tuple[float, float], tuple[float, float]],
    viscous: Modulation,
    options: FitOptions,
    residual: PhaseResidual,
) -> tuple[PeriodFit, PhaseResidual]:
    """Eq 23's ``fit`` under the damping model the data support (:func:`select_damping`).

    Args:
        fit: Eq 23's fit.
        blocks: The block means it was made on.
        viscous_fit: Its solution (scaled units).
        samples: The window's samples (in the fit's sample units), and what gives their times
            from the window centre [s] (only asked for when another model is chosen).
        units: (scale, offset) from the scaled units to the samples' units, and to the
            caller's.
        viscous: Eq 23's beating statistics.
        options: The fit's options.
        residual: Eq 23's per-cycle departures.

    Returns:
        ``fit`` itself when Eq 23 stands (or the other models fail, noted), else
        :func:`apply_damping`'s fit — unless it does not fit the samples better than Eq 23
        (the block-mean models are approximate with uneven samples); and the returned fit's
        per-cycle departures from its model.
    """
    if not viscous.significance >= TRY_FROM:
        return fit, residual  # Eq 23's envelope and phase stand out of nothing: it fits
    try:
        choice = select_damping(blocks, viscous_fit, fit.n_cycles)
    except FitFailed as exc:
        note = f"the dry-friction damping models could not be fitted ({exc})"
        return replace(fit, notes=(*fit.notes, note)), residual
    env = choice.fit
    if env is None:
        return fit, residual
    y, tau_of = samples
    chosen = apply_damping(fit, choice, env, y, tau_of(), units[0], units[1], viscous, options)
    if not chosen.residual_rms < fit.residual_rms:
        return replace(fit, notes=(*fit.notes, f"{choice.describe()}, but Eq 23 fits the samples as well")), residual
    return chosen, phase_residual(env)
