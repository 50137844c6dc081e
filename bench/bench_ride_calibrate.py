"""Ride calibration on simulated rides from a known "true" bicycle: coverage, ranking, speed.

Prints numbers, asserts nothing. The measured bicycle is the Browser (``config/bicycles``,
its measured covariance the prior), the rider the paper's, the assist the balance-assist
feedback. The "true" bicycle differs from the measured one by known shifts: **no rider**,
the gains acting at **0.7** of their nominal scale, and one inertia shifted by **+2 prior σ**.

1. **Eigenvalue level** (``--seeds``, default 300): the true closed loop's weave eigenvalue at
   20 speeds (1.5–4.5 m/s) plus normal errors of σ drawn per speed in [0.08, 0.25] 1/s (the
   σ the segment fit gives at one speed). Every variant is calibrated
   (:func:`bike_rig.core.ride.variants.calibrate`); printed: how often the true variant ("no
   rider, gain scale free") ranks first; the gain scale's coverage (|ŝ − 0.7| ≤ σ̂); for the
   shifted inertia, its posterior/prior σ ratio and its shift — IBzz, which these rides do not
   constrain (it must stay at its prior), and IFyy with a prior σ 10 times the rig's (a wheel
   inertia estimated, not measured), which they do — each shifted with the parameters the rig's
   covariance correlates with it (their mean given the shift); the coverage of every constrained
   parameter; the largest shift of any unconstrained parameter. A fixed +2 σ shift is pulled
   toward the prior by the posterior (by (σ_post/σ_prior)² of it), so its coverage is expected
   below 68 % (printed beside it; the gain scale's too: the unseen shift biases it through the
   prior); with the truth drawn from the prior (``random``, ``ifyy-random``) it is 68 %. Printed
   beside: the gain scale's mean error in its σ against the one the shifted parameter's
   confounding predicts (:meth:`bike_rig.core.ride.posterior.Posterior.gain_scale_confounders`),
   and how often the verdict names it.
2. **End to end** (``--e2e-seeds``, default 6): realistic segments
   (:func:`bike_rig.core.ride.ridesim.simulate_segment`: rider steering, a saturating motor,
   gyro noise; three segments of 1.2–2.5 cycles per speed, 8 speeds) fitted
   (:func:`bike_rig.core.ride.eigen.fit_segment`), combined per speed, calibrated: ranking and
   gain-scale coverage through the whole chain.
3. **Speed**: one calibration (all four variants) over 20 speed points, median wall time, as a
   ratio to the 2 s budget.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from timing import median_ms

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import ParameterSet
from bike_rig.core.feedback import Feedback, resolve_feedback
from bike_rig.core.ride.eigen import combine_eigenvalues, fit_segment, pool_drive
from bike_rig.core.ride.posterior import RideData
from bike_rig.core.ride.ridesim import RideConditions, simulate_segment
from bike_rig.core.ride.variants import CONSTRAINED_RATIO, calibrate
from bike_rig.core.ride.weave_model import model_weave
from bike_rig.core.rider import PAPER_RIDER
from bike_rig.core.symbols import PARAMETER_NAMES
from bike_rig.core.uncertainty.uncertain import UncertainVector
from bike_rig.core.whipple import canonical_matrices

TRUE_VARIANT = "no rider, gain scale free"
TRUE_SCALE = 0.7
SPEEDS = np.linspace(1.5, 4.5, 20)


def _inflate(ps: ParameterSet, name: str, factor: float) -> ParameterSet:
    """``ps`` with ``name``'s prior σ multiplied by ``factor`` (its correlations kept)."""
    scale = np.ones(len(PARAMETER_NAMES))
    scale[PARAMETER_NAMES.index(name)] = factor
    cov = ps.parameters.covariance * np.outer(scale, scale)
    return replace(ps, parameters=UncertainVector(PARAMETER_NAMES, ps.parameters.values, cov))


def _truth(ps: ParameterSet, name: str, rng: np.random.Generator | None) -> np.ndarray:
    """The true parameters: ``name`` +2 prior σ, the parameters correlated with it at their mean given it.

    (The rig's covariance: an error in ``name``'s readings moves them too.) With ``rng``: instead a
    draw of the prior (no shift).
    """
    if rng is not None:
        return np.asarray(rng.multivariate_normal(ps.parameters.values, ps.parameters.covariance, method="eigh"))
    j = PARAMETER_NAMES.index(name)
    cov = ps.parameters.covariance
    return np.asarray(ps.parameters.values + 2.0 * cov[:, j] / math.sqrt(cov[j, j]))


def _data(truth: np.ndarray, fb: Feedback, rng: np.random.Generator, noise: bool = True) -> RideData:
    lam, _, _ = model_weave(
        dict(zip(PARAMETER_NAMES, truth, strict=True)), SPEEDS, fb, TRUE_SCALE, np.full(SPEEDS.size, -3 + 10j)
    )
    sr, si = rng.uniform(0.08, 0.25, SPEEDS.size), rng.uniform(0.08, 0.25, SPEEDS.size)
    if not noise:
        return RideData(SPEEDS, lam.real, sr, lam.imag, si)
    return RideData(SPEEDS, lam.real + rng.normal(0, sr), sr, lam.imag + rng.normal(0, si), si)


def eigenvalue_campaign(ps: ParameterSet, fb: Feedback, name: str, seeds: int, random_truth: bool) -> None:
    j = PARAMETER_NAMES.index(name)
    first = scale_in = shift_in = constrained_in = constrained_n = 0
    ratios, shifts, loose_max, expected = [], [], 0.0, []
    observed_bias, predicted_bias, named = [], [], 0
    scale_expected = 0.6827
    if not random_truth:  # the fixed shift biases the gain scale through the prior: by how much, without noise
        exact = _data(_truth(ps, name, None), fb, np.random.default_rng(0), noise=False)
        post0 = next(r.posterior for r in calibrate(ps, exact, PAPER_RIDER, fb).variants if r.name == TRUE_VARIANT)
        scale_expected = _covered((post0.gain_scale - TRUE_SCALE) / post0.gain_scale_sigma)
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        truth = _truth(ps, name, rng if random_truth else None)
        cal = calibrate(ps, _data(truth, fb, rng), PAPER_RIDER, fb)
        first += cal.best.name == TRUE_VARIANT
        post = next(r.posterior for r in cal.variants if r.name == TRUE_VARIANT)
        scale_in += abs(post.gain_scale - TRUE_SCALE) <= post.gain_scale_sigma
        observed_bias.append((post.gain_scale - TRUE_SCALE) / post.gain_scale_sigma)
        lean = {c.name: c.in_sigma for c in post.gain_scale_confounders(share=0.0)}
        predicted_bias.append(0.0 if random_truth else 2.0 * lean.get(name, 0.0))
        named += name in {c.name for c in post.gain_scale_confounders()}
        ratio = post.sigma_ratio
        ratios.append(float(ratio[j]))
        shifts.append(float(post.shifts[j]))
        shift_in += abs(post.values[j] - truth[j]) <= post.sigmas[j]
        expected.append(_expected_coverage(float(ratio[j])) if not random_truth else 0.6827)
        if seed < 2 and not random_truth:
            print(f"    seed {seed}: {cal.verdict[:240]}…")
        for i in range(len(PARAMETER_NAMES)):
            if ps.parameters.sigmas[i] == 0:
                continue
            if ratio[i] < CONSTRAINED_RATIO:
                constrained_n += 1
                constrained_in += abs(post.values[i] - truth[i]) <= post.sigmas[i]
            elif i != j and not random_truth:
                loose_max = max(loose_max, abs(float(post.shifts[i])))
    how = (
        f"the truth drawn from the prior, {name}'s prior σ {ps.parameters.sigma(name):.4g}"
        if random_truth
        else f"{name} +2σ = {2 * ps.parameters.sigma(name):.4g}, correlated parameters with it"
    )
    print(f"  {how}: {seeds} seeds")
    print(f"    true variant '{TRUE_VARIANT}' ranked first: {first / seeds:.1%}")
    print(
        f"    gain scale within its posterior σ of {TRUE_SCALE}: {scale_in / seeds:.1%} "
        f"(expected {scale_expected:.1%}: the bias of a noise-free ride's posterior)"
    )
    print(
        f"    gain scale's error in its σ: mean {np.mean(observed_bias):+.2f}, SD {np.std(observed_bias):.2f}; "
        f"the shift of {name} predicts {np.mean(predicted_bias):+.2f} (Posterior.gain_scale_confounders); "
        f"{name} named a confounder of the gain scale in {named / seeds:.0%} of the verdicts"
    )
    true = "a draw of the prior" if random_truth else "+2.00"
    print(
        f"    {name}: posterior/prior σ median {np.median(ratios):.2f}; shift recovered median "
        f"{np.median(shifts):+.2f} prior σ (true {true})"
    )
    print(
        f"    {name} within its posterior σ of the truth: {shift_in / seeds:.1%} "
        f"(expected {np.mean(expected):.1%} for this σ ratio)"
    )
    if constrained_n:
        print(
            f"    every constrained parameter (σ ratio < {CONSTRAINED_RATIO}) within its posterior σ: "
            f"{constrained_in / constrained_n:.1%} of {constrained_n}"
        )
    if not random_truth:
        print(f"    largest shift of any unconstrained parameter (truth = prior mean): {loose_max:.2f} prior σ")


def _covered(bias: float) -> float:
    """P(|x − truth| ≤ σ) for a normal estimate x biased by ``bias`` σ."""
    from scipy.stats import norm

    return float(norm.cdf(1.0 - bias) - norm.cdf(-1.0 - bias))


def _expected_coverage(ratio: float) -> float:
    """P(|posterior − truth| ≤ σ_post) for a fixed +2 σ0 truth, one linear Gaussian parameter.

    With r = σ_post/σ0 the posterior mean is pulled toward the prior by r² · 2 σ0 (2r posterior σ)
    and scatters over the rides' noise by sqrt(1 − r²) posterior σ.
    """
    from scipy.stats import norm

    r = min(ratio, 1.0)
    bias, spread = 2.0 * r, math.sqrt(max(1.0 - r * r, 1e-12))
    return float(norm.cdf((1.0 - bias) / spread) - norm.cdf((-1.0 - bias) / spread))


def end_to_end(ps: ParameterSet, fb: Feedback, seeds: int, saturation: float, rate: float | None) -> None:
    speeds = np.linspace(1.5, 4.5, 8)
    truth = _truth(ps, "IBzz", None)
    mats = canonical_matrices(dict(zip(PARAMETER_NAMES, truth, strict=True)))
    g = float(truth[PARAMETER_NAMES.index("g")])
    conditions = RideConditions(saturation=saturation)
    first = scale_in = n = 0
    sig_re, sig_im, times = [], [], []
    for seed in range(seeds):
        rng = np.random.default_rng(1000 + seed)
        segments = []
        for v in speeds:
            for _ in range(3):
                sim = simulate_segment(
                    mats, g, float(v), TRUE_SCALE * fb.gains(float(v)), float(rng.uniform(1.2, 2.5)), conditions, rng
                )
                segments.append(fit_segment(sim.times, sim.roll_rate, speed=float(v)))
        combined = [c for c in combine_eigenvalues(pool_drive(segments)) if c.n_used]
        sig_re += [c.real_sigma for c in combined]
        sig_im += [c.imag_sigma for c in combined]
        t0 = time.perf_counter()
        cal = calibrate(ps, RideData.from_combined(combined), PAPER_RIDER, fb, rate_hz=rate)
        times.append(time.perf_counter() - t0)
        n += 1
        first += cal.best.name == TRUE_VARIANT
        post = next(r.posterior for r in cal.variants if r.name == TRUE_VARIANT)
        scale_in += abs(post.gain_scale - TRUE_SCALE) <= post.gain_scale_sigma
        print(
            f"    seed {seed}: best '{cal.best.name}', χ²/dof {cal.best.reduced_chi2:.2f}, gain scale "
            f"{post.gain_scale:.3f} ± {post.gain_scale_sigma:.3f}"
        )
    model = f"assist modelled sampled at {rate:g} Hz" if rate else "assist modelled continuous"
    print(
        f"  end to end, motor saturation {saturation:g} N m, {model}, {n} rides of {speeds.size} speeds × 3 "
        f"segments: true variant first {first}/{n}, gain scale within σ {scale_in}/{n}"
    )
    print(
        f"    combined σ per speed: Re λ median {np.median(sig_re):.3f} 1/s, Im λ median {np.median(sig_im):.3f} rad/s"
    )


def speed(ps: ParameterSet, fb: Feedback) -> None:
    rng = np.random.default_rng(0)
    data = _data(_truth(ps, "IBzz", None), fb, rng)
    ms = median_ms(lambda: calibrate(ps, data, PAPER_RIDER, fb), repeat=7)
    sampled = median_ms(lambda: calibrate(ps, data, PAPER_RIDER, fb, rate_hz=100.0), repeat=3)
    print(
        f"  one calibration, 4 variants, {SPEEDS.size} speeds: {ms:.0f} ms median = {ms / 2000:.2f} of the 2 s budget"
    )
    print(
        f"  the same, the assist sampled at 100 Hz (forward differences): {sampled:.0f} ms median "
        f"= {sampled / 2000:.2f} of the 2 s budget"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=300)
    parser.add_argument("--e2e-seeds", type=int, default=6)
    parser.add_argument(
        "--scenarios",
        default="ibzz,ifyy,ifyy-random,random",
        help="eigenvalue-level scenarios, comma-separated (default all)",
    )
    args = parser.parse_args()
    ps = _parameters(str(config_file("bicycles/browser.yaml")), "centroid")
    fb = resolve_feedback(str(config_file("feedback/balance_assist.yaml")))
    assert fb is not None
    print("speed:")
    speed(ps, fb)
    wheel = _inflate(ps, "IFyy", 10.0)
    scenarios = {
        "ibzz": (ps, "IBzz", False),
        "ifyy": (wheel, "IFyy", False),
        "ifyy-random": (wheel, "IFyy", True),
        "random": (ps, "IBzz", True),
    }
    chosen = [s for s in args.scenarios.split(",") if s]
    if args.seeds and chosen:
        print("eigenvalue level:")
    for key in chosen if args.seeds else []:
        bicycle, name, random_truth = scenarios[key]
        eigenvalue_campaign(bicycle, fb, name, args.seeds, random_truth)
    if args.e2e_seeds:
        print("end to end (ridesim → fit_segment → combine → calibrate):")
        rate = RideConditions().rate_hz  # ridesim's assist holds its torque over each sample
        end_to_end(ps, fb, args.e2e_seeds, math.inf, rate)
        end_to_end(ps, fb, 2, math.inf, None)
        end_to_end(ps, fb, 2, RideConditions().saturation, rate)  # the motor saturates most of the time


if __name__ == "__main__":
    main()
