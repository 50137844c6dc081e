"""Where a raw-log segment's end error comes from: the noise level, the end's definition, the fit.

Prints numbers, asserts nothing. On simulated raw logs (as ``bench_ride_segments.py``, roll rate
and wheel speed) each found push's segment end (:func:`bike_rig.core.ride.segment.segment_record`)
is compared with the truth (where the push's own response falls to twice the riding's RMS,
:class:`bike_rig.core.sim.ride_log.PushTruth`), and the error is taken apart:

* **takeover**: the share of ends by the takeover test (those lie on the half-cycle grid; the
  envelope's ends are its model's crossing, interpolated);
* **noise**: the segmenter's noise level over the truth's (the riding's RMS without the push),
  and the end error when the segmenter is given the truth's level;
* **definition**: the end of the same decaying-sinusoid model fitted to the push's own response
  (no riding) at the truth's level, less the truth: the model's envelope against the truth's
  analytic-signal envelope;
* **bound**: the Cramér–Rao bound σ_T of the end time ``T = ln(A/level)/(−σ)`` of that model
  under the riding's own noise (its autocovariance from the log's riding at cruise within 30 s
  of the push, less the pushes' responses, over the truth's decay and 2 s beyond), and the σ_T
  of the ordinary least-squares fit under that noise, and of the fit the segmenter makes: the
  generalised least squares whitened by the AR model of the 4 s of riding before the push
  (:mod:`bike_rig.core.ride.whiten`; "whitened" is the share of pushes whose riding gives a
  model, the others are fitted by ordinary least squares); "≤ 0.3 s if Gaussian" is the share
  a Gaussian error of the bound's σ_T puts within 0.3 s; σ_rob is the end error's robust σ
  (1.4826 × its median |·|), to compare with σ_T (the errors' tails are heavier than a
  Gaussian's).

``--noise-order 0`` makes the segmenter's fit ordinary least squares, for comparison.
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from scipy.linalg import cho_factor, cho_solve, toeplitz

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.ride import segment as seg_mod
from bike_rig.core.ride.record import RideRecord
from bike_rig.core.ride.whiten import NoiseAR, fit_noise_ar
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.sim.ride_log import PushTruth, SimulatedLog, ride_plan, simulate_raw_log
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma

#: A segment's kick this close to a push [s] finds it.
FOUND_S = 0.3


def _model_end(
    t: np.ndarray, y: np.ndarray, floor: float, opt: seg_mod.SegmentOptions, ar: NoiseAR | None = None
) -> float:
    """The segmenter's decay end of ``y`` with the noise level ``floor`` [s] and noise model ``ar`` (NaN: none)."""
    end = seg_mod._free_decay_end(t, y, floor, opt, ar).end
    return math.nan if end is None else end


def _bound(
    log: SimulatedLog, push: PushTruth, background: np.ndarray, opt: seg_mod.SegmentOptions, ar: NoiseAR | None
) -> tuple[float, ...]:
    """(definition error, Cramér–Rao σ_T, least-squares σ_T, whitened σ_T) [s] of one push (module docstring)."""
    t = log.times
    i = int(np.searchsorted(t, push.time))
    tt = t[i : i + push.response.size]
    win = (tt >= push.start) & (tt <= push.stop + 2.0)
    x, s = tt[win] - push.start, push.response[win]
    definition = _model_end(x + push.start, s, push.level / 2.0, opt) - push.stop
    half = seg_mod._half_period(x, s, opt)
    if half is None:
        return definition, math.nan, math.nan, math.nan
    w = math.pi / half
    basis = np.column_stack([np.ones(x.size), np.cos(w * x), np.sin(w * x)])
    c, a, b = np.linalg.lstsq(basis, s, rcond=None)[0]
    theta = seg_mod._fit_decay(x, s, np.array([c, 0.0, w, a, b]))
    if theta is None:
        return definition, math.nan, math.nan, math.nan
    near = (log.speed > 0.95 * float(np.max(log.speed))) & (np.abs(t - push.time) < 30.0)
    r = background[near] - np.mean(background[near])
    acov = np.array([np.dot(r[: r.size - k], r[k:]) / r.size for k in range(x.size)])
    cov = toeplitz(acov) + 1e-12 * np.eye(x.size)
    eye = np.eye(5)
    jac = np.column_stack(
        [(seg_mod._decay_model(theta + 1e-6 * e, x) - seg_mod._decay_model(theta - 1e-6 * e, x)) / 2e-6 for e in eye]
    )
    grad = np.array(
        [
            (seg_mod._fades(0.0, theta + 1e-5 * e, push.level) - seg_mod._fades(0.0, theta - 1e-5 * e, push.level))
            / 2e-5
            for e in eye
        ]
    )
    info = jac.T @ cho_solve(cho_factor(cov), jac)
    inv = np.linalg.inv(jac.T @ jac)
    crlb = math.sqrt(float(grad @ np.linalg.solve(info, grad)))
    ls = math.sqrt(float(grad @ inv @ jac.T @ cov @ jac @ inv @ grad))
    if ar is None:
        return definition, crlb, ls, ls
    white = ar.whiten(np.eye(x.size))  # the whitening matrix W: W r = ar.whiten(r)
    wj = white @ jac
    m = np.linalg.inv(wj.T @ wj)
    gls = math.sqrt(float(grad @ m @ wj.T @ (white @ cov @ white.T) @ wj @ m @ grad))
    return definition, crlb, ls, gls


def run(speed: float, seeds: range, matrices: object, g: float, order: int) -> dict[str, float]:
    """The breakdown over ``seeds`` logs at ``speed`` [m/s] with three pushes each (``order``: the AR's largest)."""
    opt = seg_mod.SegmentOptions(noise_order=order)
    err, takeover, ratio, with_truth, definition, crlb, ls, gls = [], [], [], [], [], [], [], []
    whitened = 0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        log = simulate_raw_log(matrices, g, ride_plan(179.0, speed, 3, rng), rng)  # type: ignore[arg-type]
        t, y = log.times, log.roll_rate
        record = RideRecord("log", t, y, speed=log.wheel_speed)
        detrended = y - seg_mod._baseline(t, y, opt)
        sigma = seg_mod.noise_sigma(y)
        background = y.copy()
        for p in log.pushes:
            i = int(np.searchsorted(t, p.time))
            background[i : i + p.response.size] -= p.response
        background -= seg_mod._baseline(t, background, opt)
        for seg in seg_mod.segment_record(record, opt).segments:
            hits = [p for p in log.pushes if abs(seg.kick.onset - p.time) <= FOUND_S]
            if not hits:
                continue
            push = hits[0]
            err.append(seg.stop - push.stop)
            takeover.append("took over" in seg.stop_reason)
            lead = seg.kick.onset - 0.25 * opt.window_s
            before = (t >= lead - opt.riding_s) & (t < lead)
            ratio.append(max(float(np.sqrt(np.mean(detrended[before] ** 2))), sigma) / (push.level / 2.0))
            ar = fit_noise_ar(detrended[before], opt.noise_order)  # (as the segmenter's, pushes 4 s apart)
            whitened += ar is not None
            inside = (t >= seg.start) & (t <= seg.start + opt.max_length_s)
            with_truth.append(_model_end(t[inside], detrended[inside], push.level / 2.0, opt, ar) - push.stop)
            d, c, q, u = _bound(log, push, background, opt, ar)
            definition.append(d)
            crlb.append(c)
            ls.append(q)
            gls.append(u)
    e, et, de = np.abs(err), np.abs(with_truth), np.abs(definition)
    gauss = np.array([math.erf(0.3 / (c * math.sqrt(2.0))) for c in crlb if math.isfinite(c)])
    return {
        "n": float(e.size),
        "within": float(np.mean(e <= 0.3)),
        "p90": float(np.percentile(e, 90)),
        "robust": float(1.482602218505602 * np.median(e)),
        "takeover": float(np.mean(takeover)),
        "ratio": float(np.median(ratio)),
        "ratio10": float(np.percentile(ratio, 10)),
        "ratio90": float(np.percentile(ratio, 90)),
        "truth_within": float(np.nanmean(et <= 0.3)),
        "def50": float(np.nanmedian(de)),
        "def90": float(np.nanpercentile(de, 90)),
        "crlb": float(np.nanmedian(crlb)),
        "ls": float(np.nanmedian(ls)),
        "gls": float(np.nanmedian(gls)),
        "whitened": whitened / max(e.size, 1),
        "gauss": float(np.mean(gauss)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=20, help="logs per row (default 20)")
    parser.add_argument("--speeds", type=float, nargs="+", default=[5.0, 4.17, 3.33, 2.5, 1.67])
    parser.add_argument(
        "--noise-order",
        type=int,
        default=seg_mod.SegmentOptions().noise_order,
        help="the riding's AR model's largest order (0: ordinary least squares)",
    )
    args = parser.parse_args()
    ms = canonical_with_sigma(
        add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    )
    print(
        f"{args.seeds} simulated 179 s logs per row, roll rate and wheel speed; end error = segment stop less truth; "
        f"the riding's AR model up to order {args.noise_order}"
    )
    print(
        f"{'km/h':>5} {'n':>3} {'≤0.3 s':>6} {'p90':>5} {'σ_rob':>5} {'takeover':>8} {'noise/truth [p10 p90]':>22} "
        f"{'≤0.3 s truth noise':>18} {'definition |·|50 p90':>20} {'CRLB σ_T':>8} {'LS σ_T':>6} {'GLS σ_T':>7} "
        f"{'whitened':>8} {'≤0.3 s Gauss':>12}"
    )
    for v in args.speeds:
        r = run(v, range(args.seeds), ms.matrices, ms.g, args.noise_order)
        print(
            f"{3.6 * v:5.1f} {r['n']:3.0f} {100 * r['within']:5.0f}% {r['p90']:5.2f} {r['robust']:5.2f} "
            f"{100 * r['takeover']:7.0f}% "
            f"{r['ratio']:8.2f} [{r['ratio10']:.2f} {r['ratio90']:.2f}] {100 * r['truth_within']:17.0f}% "
            f"{r['def50']:14.2f} {r['def90']:5.2f} {r['crlb']:8.2f} {r['ls']:6.2f} {r['gls']:7.2f} "
            f"{100 * r['whitened']:7.0f}% {100 * r['gauss']:11.0f}%",
            flush=True,
        )


if __name__ == "__main__":
    main()
