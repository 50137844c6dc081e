"""A digital assist's weave: the raw-log simulator's sampled loop against the model with and without the rate.

Prints numbers, asserts nothing. For each bicycle (with the paper's rider) and speed the truth is
the simulator's own loop (:mod:`bike_rig.core.sim.ride_log`: ``scipy.signal.cont2discrete`` of the
open loop at its rounded speed, the feedback's gains, ``ln eig(Φ − Γ_δ K) / T``); the model is
``ride validate``'s :func:`bike_rig.pipeline.ride.predicted_weave` for the continuous feedback and
for the same feedback with ``rate_hz``. Columns: the gaps model − truth in % of ω = Im λ and of
|Re λ|, and the model's σ of each part in the same %.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np
from scipy.signal import cont2discrete

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.feedback import Feedback, GainSchedule, load_feedback
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.sim.ride_log import SPEED_STEP
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import state_space
from bike_rig.pipeline.ride import predicted_weave


def _simulator_weave(ms: object, v: float, fb: Feedback, rate: float) -> complex:
    """The weave eigenvalue of the simulator's sampled loop at ``v`` [m/s] (on its speed grid) [1/s]."""
    a, b = (np.asarray(m, dtype=float) for m in state_space(ms.matrices, v, ms.g))  # type: ignore[attr-defined]
    ad, bd, *_ = cont2discrete((a, b, np.eye(4), np.zeros((4, 2))), 1.0 / rate, method="zoh")
    z = np.linalg.eigvals(np.asarray(ad) - np.outer(np.asarray(bd)[:, 1], fb.gains(v)))
    lam = np.log(z.astype(complex)) * rate
    return complex(max(lam, key=lambda x: x.imag))


#: :func:`bike_rig.core.sim.ride_log.assist_gains` as a feedback.
SIMULATOR_ASSIST = Feedback(
    "the simulator's own assist",
    k_phidot=GainSchedule((2.0, 10.0 / 3.0, 5.0), (-50.0, -25.0, -20.0)),
    k_deltadot=GainSchedule.constant(1.0),
)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bicycles", default="browser,crescendo")
    p.add_argument("--feedback", default=str(config_file("feedback/balance_assist.yaml")))
    p.add_argument("--rate", type=float, default=100.0, help="the controller's rate [Hz]")
    p.add_argument("--kmh", default="6,9,12,15,18")
    args = p.parse_args()
    fb = SIMULATOR_ASSIST if args.feedback == "simulator" else load_feedback(args.feedback)
    sampled = replace(fb, rate_hz=args.rate)
    speeds = np.array([round(float(k) / 3.6 / SPEED_STEP) * SPEED_STEP for k in args.kmh.split(",")])
    print(f"feedback {fb.name}, controller {args.rate:g} Hz; gaps model − simulator in % (ω, Re λ)")
    print(
        "bicycle     km/h  simulator λ [1/s]    continuous: dω %   dRe %  dRe 1/s"
        "   sampled: dω %     dRe %   σω %  σRe %"
    )
    for name in args.bicycles.split(","):
        ps = add_rider(_parameters(str(config_file(f"bicycles/{name}.yaml")), "centroid"), PAPER_RIDER)
        ms = canonical_with_sigma(ps)
        truth = [_simulator_weave(ms, float(v), fb, args.rate) for v in speeds]
        near = np.array(truth)
        cont = predicted_weave(ps, speeds, fb, near=near)
        samp = predicted_weave(ps, speeds, sampled, near=near)
        for i, v in enumerate(speeds):
            t = truth[i]

            def gap(pred: object, i: int = i, t: complex = t) -> tuple[float, float]:
                w = 100 * (pred.imag[i] - t.imag) / t.imag  # type: ignore[attr-defined]
                r = 100 * (pred.real[i] - t.real) / abs(t.real)  # type: ignore[attr-defined]
                return float(w), float(r)

            cw, cr = gap(cont)
            sw, sr = gap(samp)
            sig_w = 100 * samp.imag_sigma[i] / t.imag
            sig_r = 100 * samp.real_sigma[i] / abs(t.real)
            print(
                f"{name:10s} {3.6 * v:5.2f}  {t.real:+.4f}{t.imag:+.4f}i   {cw:+8.3f} {cr:+8.3f} "
                f"{cont.real[i] - t.real:+7.4f}   "
                f"{sw:+.1e} {sr:+.1e}  {sig_w:5.2f} {sig_r:5.2f}"
            )


if __name__ == "__main__":
    main()
