"""Model variants compared against the rides: rider aboard or not, a gain scale, freed parameters.

Each variant is a prior (the bicycle's parameter set, or the bicycle with the rider added) and
its unknowns without a prior (:class:`~.posterior.Unknowns`); :func:`calibrate` computes each
one's posterior (:func:`~.posterior.posterior`) and ranks them by the Laplace evidence
``−2 ln Z = χ² + ln det H − k ln 2π + 2 Σ ln W`` (``H`` the whitened Hessian: the Occam factor
of the prior-constrained parameters; ``k`` unknowns without a prior, each with a uniform prior
of width ``W``: :data:`GAIN_SCALE_RANGE` for the gain scale, :data:`FREE_RANGE` prior σ for a
freed parameter), beside AIC ``χ² + 2k`` and BIC ``χ² + k ln N``. ``χ²`` is the data's plus
the prior's term; its degrees of freedom are the data values less ``k``.

The verdict in words (:func:`describe`) says which variant explains the rides (χ² probability
above :data:`MIN_P`), at what gain scale, how far the parameters move (in prior σ), which
parameters the rides constrain (posterior / prior σ below :data:`CONSTRAINED_RATIO`; the rest
stay at their prior), which parameters' priors the gain scale's estimate leans on
(:meth:`~.posterior.Posterior.gain_scale_confounders`), what the rides cannot determine, and
where the linearisation does not hold; or that no variant explains the rides. A saturating
assist is not a variant of its own: eigenvalues are small-signal quantities, and a motor that
saturates acts on them as a lower gain scale, which the gain-scale variants measure.
Units: SI; eigenvalues 1/s; gain scale dimensionless.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2 as chi2_distribution

from ..benchmark import ParameterSet
from ..feedback import Feedback
from ..rider import AnyRider, add_rider
from ..symbols import PARAMETER_NAMES
from .posterior import Posterior, RideData, Unknowns, posterior

__all__ = [
    "CONSTRAINED_RATIO",
    "FREE_RANGE",
    "GAIN_SCALE_RANGE",
    "MIN_P",
    "RideCalibration",
    "VariantResult",
    "calibrate",
    "describe",
]

#: Width of the gain scale's uniform prior [-] (0 to 2 times the nominal gains).
GAIN_SCALE_RANGE = 2.0
#: Width of a freed parameter's uniform prior, in its prior σ.
FREE_RANGE = 20.0
#: A variant whose χ² has a smaller upper-tail probability does not explain the rides.
MIN_P = 0.01
#: A parameter whose posterior σ is below this fraction of its prior σ is constrained by the rides.
CONSTRAINED_RATIO = 0.8
#: Unknowns without a prior correlated beyond this are not separately determined.
DEGENERATE = 0.95
#: Variants closer than this in −2 ln Z are not told apart.
INDISTINCT = 2.0


@dataclass(frozen=True)
class VariantResult:
    """One variant's fit.

    Attributes:
        name: Short label (``no rider, gain scale free``).
        rider: Whether the rider is aboard.
        posterior: Its posterior.
        k: Unknowns without a prior.
        aic: χ² + 2k.
        bic: χ² + k ln N.
        evidence: −2 ln Z (Laplace, module docstring); lower is better.
        p_value: Upper-tail probability of χ² with its degrees of freedom (NaN without any).
    """

    name: str
    rider: bool
    posterior: Posterior
    k: int
    aic: float
    bic: float
    evidence: float
    p_value: float

    @property
    def reduced_chi2(self) -> float:
        """χ² / dof (NaN without degrees of freedom)."""
        dof = self.posterior.dof
        return self.posterior.chi2 / dof if dof > 0 else math.nan


@dataclass(frozen=True)
class RideCalibration:
    """Every variant's fit, best first, and the verdict.

    Attributes:
        data: The measured eigenvalues.
        variants: Ranked by evidence (best first).
        feedback: The feedback (None: open loop).
        verdict: The result in words.
        explained: Whether the best variant explains the rides.
        notes: What was not tried, and why.
    """

    data: RideData
    variants: tuple[VariantResult, ...]
    feedback: Feedback | None
    verdict: str
    explained: bool
    notes: tuple[str, ...]

    @property
    def best(self) -> VariantResult:
        """The best variant."""
        return self.variants[0]


def _name(rider: bool | None, unknowns: Unknowns, has_feedback: bool) -> str:
    parts = [] if rider is None else ["rider aboard" if rider else "no rider"]
    if has_feedback:
        parts.append("gain scale free" if unknowns.gain_scale else "nominal gains")
    if unknowns.free:
        parts.append(f"{', '.join(unknowns.free)} free")
    return ", ".join(parts) or "the prior model"


def _widths(unknowns: Unknowns) -> list[float]:
    """The uniform prior widths of the unknowns without a prior, in ``z`` order (freed parameters, gain scale)."""
    return [FREE_RANGE] * len(unknowns.free) + [GAIN_SCALE_RANGE] * int(unknowns.gain_scale)


def _result(name: str, rider: bool, post: Posterior, n_data: int) -> VariantResult:
    k = post.unknowns.count
    log_det = post.log_det_hessian
    occam = 0.0
    if k:
        cov_tt = post.z_covariance[-k:, -k:]
        sigma_t = np.sqrt(np.diag(cov_tt))
        if np.all(np.isfinite(cov_tt)):
            log_det += float(np.linalg.slogdet(cov_tt)[1])  # ln det H_uu: the prior-constrained part alone
        for w, s in zip(_widths(post.unknowns), sigma_t, strict=True):
            occam += max(0.0, math.log(w**2 / (2 * math.pi * s**2))) if math.isfinite(s) and s > 0 else 0.0
    evidence = post.chi2 + log_det + occam
    if post.undetermined or loose(post):
        evidence = math.inf  # the rides do not determine an unknown: the Laplace evidence is not defined
    p = float(chi2_distribution.sf(post.chi2, post.dof)) if post.dof > 0 else math.nan
    return VariantResult(name, rider, post, k, post.chi2 + 2 * k, post.chi2 + k * math.log(n_data), evidence, p)


def loose(post: Posterior) -> list[str]:
    """The freed parameters the rides do not determine: posterior σ wider than their uniform prior's."""
    n = len(post.unknowns.free)
    if not n:
        return []
    sigma = np.sqrt(np.diag(post.z_covariance))[-post.unknowns.count :][:n]
    return [f for f, s in zip(post.unknowns.free, sigma, strict=True) if not s * math.sqrt(12.0) < FREE_RANGE]


def calibrate(
    bicycle: ParameterSet,
    data: RideData,
    rider: AnyRider | None = None,
    feedback: Feedback | None = None,
    free: Sequence[str] = (),
    rider_aboard: bool | None = None,
    rate_hz: float | None = None,
) -> RideCalibration:
    """Every variant's posterior, ranked, and the verdict (module docstring).

    Args:
        bicycle: The measured bicycle (values and covariance), without a rider.
        data: The measured weave eigenvalues per speed.
        rider: The rider (None: only the bicycle alone is tried).
        feedback: The assist's feedback (None: the open loop, no gain scale).
        free: Parameters freed from their prior in further variants.
        rider_aboard: Try only this (True / False); None: both where a rider is given.
        rate_hz: The assist's sample rate [Hz]: a digital assist holding its torque over each
            sample (None: continuous; :func:`~.posterior.model_weave`).

    Raises:
        CalibrationDataError: An unknown parameter in ``free``.
        ModelError: A singular mass matrix.
    """
    notes = list(data.notes)
    if not np.any(bicycle.parameters.sigmas > 0):
        notes.append(
            "the parameters have no σ (an exact prior, e.g. a parameter file without σ): they cannot "
            "move; only each variant's gain scale and freed parameters are fitted"
        )
    priors: list[tuple[bool, ParameterSet]] = []
    if rider is None:
        priors.append((False, bicycle))
        notes.append("no rider given: only the bicycle alone is tried")
    else:
        if rider_aboard in (None, False):
            priors.append((False, bicycle))
        if rider_aboard in (None, True):
            priors.append((True, add_rider(bicycle, rider)))
    scales = (False, True) if feedback is not None else (False,)
    if feedback is None:
        notes.append("no feedback given: the open loop, no gain scale")
    else:
        how = f"sampled at {rate_hz:g} Hz (its torque held over each sample)" if rate_hz else "continuous"
        notes.append(f"the assist is modelled {how}")
        notes.append(
            "a saturating assist is not a variant of its own: an eigenvalue is a small-signal quantity, and "
            "saturation acts on it as a lower gain scale, which the gain-scale variants measure"
        )
    frees = [()] + ([tuple(free)] if free else [])
    results = []
    for aboard, prior in priors:
        for scale in scales:
            for names in frees:
                u = Unknowns(names, scale)
                label = _name(aboard if rider is not None else None, u, feedback is not None)
                if u.count >= data.size:
                    notes.append(
                        f"'{label}' not tried: {u.count} unknowns without a prior for {data.size} data "
                        "values (rank deficient: the rides cannot determine them)"
                    )
                    continue
                post = posterior(prior, data, feedback, u, rate_hz)
                results.append(_result(label, aboard, post, data.size))
    ranked = tuple(sorted(results, key=lambda r: (r.evidence, r.posterior.chi2)))
    text, explained = describe(ranked, feedback is not None, rider is not None)
    return RideCalibration(data, ranked, feedback, text, explained, tuple(notes))


def _pm(x: float, s: float) -> str:
    if not math.isfinite(s):
        return f"{x:.3g} (not determined)"
    digits = max(0, 1 - int(math.floor(math.log10(s)))) if s > 0 else 3
    return f"{x:.{digits}f} ± {s:.{digits}f}"


def _largest_shift(post: Posterior) -> tuple[str, float]:
    shifts = post.shifts
    prior_free = [i for i, n in enumerate(PARAMETER_NAMES) if n not in post.unknowns.free]
    if not prior_free:
        return "", 0.0
    i = max(prior_free, key=lambda j: abs(shifts[j]))
    return PARAMETER_NAMES[i], float(shifts[i])


def constrained(post: Posterior) -> list[tuple[str, float]]:
    """The parameters the rides constrain: (name, posterior/prior σ), tightest first."""
    ratio = post.sigma_ratio
    out = [
        (n, float(ratio[i]))
        for i, n in enumerate(PARAMETER_NAMES)
        if post.prior.parameters.sigmas[i] > 0 and ratio[i] < CONSTRAINED_RATIO
    ]
    return sorted(out, key=lambda p: p[1])


def _degenerate(post: Posterior) -> list[tuple[str, str, float]]:
    """Pairs of unknowns without a prior whose posterior correlation exceeds :data:`DEGENERATE` in size."""
    names = [*post.unknowns.free, *(["the gain scale"] if post.unknowns.gain_scale else [])]
    n = len(names)
    cov = post.z_covariance[-n:, -n:] if n else np.zeros((0, 0))
    out = []
    for i in range(n):
        for j in range(i + 1, n):
            denom = math.sqrt(cov[i, i] * cov[j, j])
            if math.isfinite(denom) and denom > 0 and abs(cov[i, j] / denom) > DEGENERATE:
                out.append((names[i], names[j], float(cov[i, j] / denom)))
    return out


def describe(ranked: Sequence[VariantResult], has_feedback: bool, has_rider: bool) -> tuple[str, bool]:
    """The verdict in words, and whether the best variant explains the rides."""
    best = ranked[0]
    post = best.posterior
    fit = f"χ² = {post.chi2:.1f} for {post.dof} dof" if post.dof > 0 else f"χ² = {post.chi2:.1f}, no dof left"
    if post.dof > 0 and best.p_value < MIN_P:
        tried = f"{len(ranked)} variants tried" if len(ranked) > 1 else "the one variant tried"
        loop = "with this controller " if has_feedback else ""
        text = (
            f"no variant explains the rides (χ²/dof = {best.reduced_chi2:.1f} for the best, '{best.name}'; "
            f"{tried}): the Whipple model {loop}does not describe this bicycle at these speeds"
        )
        if not post.linearity.valid:
            text += ". " + "; ".join(post.linearity.notes)
        return text, False
    parts = []
    if has_feedback and post.unknowns.gain_scale:
        parts.append(f"the gains acting at {_pm(post.gain_scale, post.gain_scale_sigma)} of their nominal scale")
    elif has_feedback:
        parts.append("the gains at their nominal scale")
    else:
        parts.append("the open-loop model")
    if has_rider:
        parts.append("with the rider aboard" if best.rider else "without the rider")
    wide = loose(post)
    for name in post.unknowns.free:
        i = PARAMETER_NAMES.index(name)
        if name in wide:
            parts.append(f"{name} not determined (σ wider than ±{FREE_RANGE / 2:g} prior σ)")
            continue
        parts.append(f"{name} = {_pm(float(post.values[i]), float(post.sigmas[i]))} ({post.shifts[i]:+.1f} prior σ)")
    name, shift = _largest_shift(post)
    other = " other" if post.unknowns.free else ""
    moved = (
        f"no{other} parameter moves more than {abs(shift):.1f} σ"
        if abs(shift) < 2.0
        else f"the largest shift is {name} by {shift:+.1f} prior σ"
    )
    text = f"the rides are explained by {', '.join(parts)} ({fit}); {moved}"
    if len(ranked) > 1:
        second = ranked[1]
        gap = second.evidence - best.evidence
        if gap < INDISTINCT:
            text += f"; the rides cannot tell it from '{second.name}' (Δ(−2 ln Z) = {gap:.1f})"
        elif math.isfinite(gap):
            text += f"; next best '{second.name}', Δ(−2 ln Z) = {gap:.1f}"
    return text + _confounding(post) + _constraints(post), True


#: The confounders named in the verdict at most.
MAX_CONFOUNDERS = 4


def _confounding(post: Posterior) -> str:
    """Which parameters' priors the gain scale's estimate leans on, in words (empty: none)."""
    found = post.gain_scale_confounders()[:MAX_CONFOUNDERS]
    if not found:
        return ""
    names = [c.name for c in found]
    listed = names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"
    moves = ", ".join(f"{c.per_prior_sigma:+.2g}" for c in found)
    shares = ", ".join(f"{abs(c.in_sigma):.1f}" for c in found)
    unseen = all(c.sigma_ratio >= CONSTRAINED_RATIO for c in found)
    seen = "which the rides hardly constrain" if unseen else "partly constrained by the rides"
    each = "it" if len(found) == 1 else "each"
    return (
        f". The gain scale is confounded with {listed} ({seen}): {each} one prior σ above its prior value would "
        f"move the gain scale by {moves} ({shares} of its σ, which allows for their prior σ; a truth several "
        "prior σ away biases it)"
    )


def _constraints(post: Posterior) -> str:
    """What the rides constrain, what they cannot determine, and where the linearisation fails, in words."""
    tight = constrained(post)
    n_prior = int(np.sum(post.prior.parameters.sigmas > 0))
    if tight:
        listed = ", ".join(f"{n} ({r:.2f})" for n, r in tight[:6])
        text = (
            f". The rides constrain {post.constrained_directions} combination(s) of the {n_prior} uncertain "
            f"parameters (posterior/prior σ: {listed}); the others stay at their prior"
        )
    elif n_prior == 0:
        text = ""
    else:
        text = (
            f". The rides constrain none of the {n_prior} uncertain parameters beyond the rig: all stay at their prior"
        )
    if post.undetermined:
        text += f". Not determined by these rides: {', '.join(post.undetermined)}"
    for a, b, rho in _degenerate(post):
        text += f". {a} and {b} are not separately determined (posterior correlation {rho:+.2f})"
    if not post.linearity.valid:
        text += ". " + "; ".join(post.linearity.notes)
    return text
