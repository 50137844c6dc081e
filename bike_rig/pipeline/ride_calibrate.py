"""Ride calibration: the measured segments against model variants, with the rig's parameters as the prior.

:func:`calibrate_rides` combines the clean segments per speed
(:func:`bike_rig.core.ride.eigen.combine_eigenvalues`), calibrates every variant
(:func:`bike_rig.core.ride.variants.calibrate`) and gives the best variant's weave eigenvalue
over speed at the prior and at the posterior, each with its ±σ band
(:func:`bike_rig.core.ride.posterior.weave_band`), for the figure. :func:`calibration_json`
is the JSON of everything. Units: speeds m/s, eigenvalues 1/s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..core.benchmark import ParameterSet
from ..core.feedback import Feedback
from ..core.ride.eigen import MeasuredEigenvalue, combine_eigenvalues
from ..core.ride.posterior import RideData, WeaveBand, weave_band
from ..core.ride.variants import RideCalibration, VariantResult, calibrate, constrained, loose
from ..core.rider import AnyRider
from ..core.symbols import PARAMETER_NAMES
from .ride import CURVE_FROM, CURVE_POINTS, CURVE_TO, RideSpeedError

__all__ = ["CalibratedRide", "calibrate_rides", "calibration_json"]


@dataclass(frozen=True)
class CalibratedRide:
    """The calibration and the best variant's bands.

    Attributes:
        calibration: Every variant, ranked, and the verdict.
        prior_band: The best variant's weave eigenvalue over speed at its prior (nominal gain scale).
        posterior_band: The same at its posterior.
        segments: The measured segments.
    """

    calibration: RideCalibration
    prior_band: WeaveBand
    posterior_band: WeaveBand
    segments: tuple[MeasuredEigenvalue, ...]


def _targets(data: RideData, speeds: np.ndarray) -> np.ndarray:
    """The measured eigenvalue interpolated to ``speeds`` (held outside): which mode is the weave."""
    order = np.argsort(data.speeds)
    v = data.speeds[order]
    return np.asarray(np.interp(speeds, v, data.real[order]) + 1j * np.interp(speeds, v, data.imag[order]))


def calibrate_rides(
    bicycle: ParameterSet,
    segments: Sequence[MeasuredEigenvalue],
    rider: AnyRider | None = None,
    feedback: Feedback | None = None,
    free: Sequence[str] = (),
    speeds: ArrayLike | None = None,
    rate_hz: float | None = None,
) -> CalibratedRide:
    """Calibrate the bicycle's parameters and the variants against the rides (module docstring).

    Args:
        bicycle: The measured bicycle without a rider (values and covariance: the prior).
        segments: The measured segments (each with a speed).
        rider: The rider of the rider-aboard variants (None: the bicycle alone).
        feedback: The assist's feedback (None: the open loop).
        free: Parameters freed from their prior in further variants.
        speeds: The bands' speeds [m/s] (default as ``ride validate``'s curve).
        rate_hz: The assist's sample rate [Hz] (None: a continuous assist).

    Raises:
        RideSpeedError: A segment without a speed. CalibrationDataError: no clean segment, or
            an unknown parameter in ``free``. ModelError: a singular mass matrix.
    """
    for m in segments:
        if not math.isfinite(m.speed):
            raise RideSpeedError(f"{m.source}: segment {m.index} has no speed: give --speed or a speed column or topic")
    data = RideData.from_combined(combine_eigenvalues(segments))
    cal = calibrate(bicycle, data, rider, feedback, free, rate_hz=rate_hz)
    if speeds is None:
        speeds = np.linspace(CURVE_FROM, max(CURVE_TO, 1.2 * float(data.speeds.max())), CURVE_POINTS)
    v = np.asarray(speeds, dtype=float)
    near = _targets(data, v)
    best = cal.best.posterior
    prior = weave_band(best, feedback, v, near, prior=True)
    post = weave_band(best, feedback, v, near)
    return CalibratedRide(cal, prior, post, tuple(segments))


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _band_json(b: WeaveBand) -> dict[str, Any]:
    return {k: [_num(x) for x in getattr(b, k)] for k in ("speeds", "real", "real_sigma", "imag", "imag_sigma")}


def _variant_json(r: VariantResult) -> dict[str, Any]:
    p = r.posterior
    prior = p.prior.parameters
    params = {
        n: {
            "prior": float(prior.values[i]),
            "prior_sigma": float(prior.sigmas[i]),
            "posterior": float(p.values[i]),
            "posterior_sigma": float(p.sigmas[i]),
            "shift_prior_sigma": float(p.shifts[i]),
            "sigma_ratio": float(p.sigma_ratio[i]),
        }
        for i, n in enumerate(PARAMETER_NAMES)
    }
    return {
        "name": r.name,
        "rider": r.rider,
        "free": list(p.unknowns.free),
        "gain_scale_free": p.unknowns.gain_scale,
        "gain_scale": p.gain_scale,
        "gain_scale_sigma": _num(p.gain_scale_sigma),
        "gain_scale_confounders": [
            {
                "parameter": c.name,
                "shift_per_prior_sigma": c.per_prior_sigma,
                "shift_in_gain_scale_sigma": c.in_sigma,
                "sigma_ratio": c.sigma_ratio,
            }
            for c in p.gain_scale_confounders()
        ],
        "chi2": _num(p.chi2),
        "chi2_data": _num(p.chi2_data),
        "dof": p.dof,
        "reduced_chi2": _num(r.reduced_chi2),
        "p_value": _num(r.p_value),
        "k": r.k,
        "aic": _num(r.aic),
        "bic": _num(r.bic),
        "minus_2_ln_evidence": _num(r.evidence),
        "constrained_directions": p.constrained_directions,
        "constrained": [{"parameter": n, "sigma_ratio": s} for n, s in constrained(p)],
        "undetermined": [*p.undetermined, *loose(p)],
        "iterations": p.iterations,
        "model_real": [float(x) for x in p.model.real],
        "model_imag": [float(abs(x)) for x in p.model.imag],
        "linearity": {
            "valid": p.linearity.valid,
            "draws_rms": _num(p.linearity.draws_rms),
            "predicted_chi2": _num(p.linearity.predicted_chi2),
            "recomputed_chi2": _num(p.linearity.recomputed_chi2),
            "not_oscillatory": [float(x) for x in p.linearity.not_oscillatory],
            "notes": list(p.linearity.notes),
        },
        "parameters": params,
        "covariance": [[float(x) for x in row] for row in p.covariance],
    }


def calibration_json(result: CalibratedRide) -> dict[str, Any]:
    """Everything: the data, every variant (parameters, covariance, fit, criteria, checks), bands, verdict."""
    cal = result.calibration
    d = cal.data
    return {
        "data": {
            "speeds": d.speeds.tolist(),
            "real": d.real.tolist(),
            "real_sigma": d.real_sigma.tolist(),
            "imag": d.imag.tolist(),
            "imag_sigma": d.imag_sigma.tolist(),
        },
        "variants": [_variant_json(r) for r in cal.variants],
        "best": cal.best.name,
        "assist_rate_hz": cal.best.posterior.rate_hz,
        "explained": cal.explained,
        "verdict": cal.verdict,
        "notes": list(cal.notes),
        "parameter_names": list(PARAMETER_NAMES),
        "prior_band": _band_json(result.prior_band),
        "posterior_band": _band_json(result.posterior_band),
    }
