"""Bias of ride segment eigenvalues on simulated raw logs: z against the discrete loop's truth.

Prints numbers, asserts nothing. At each speed ``--seeds`` raw logs
(:func:`bike_rig.core.sim.ride_log.simulate_raw_log`: riding off and on, the rider's steering
noise, gyro noise, the assist motor's saturation, three lateral pushes each) are simulated; each
push's response is cut by hand from the push's end (:class:`~bike_rig.core.sim.ride_log.PushTruth`)
over 1.2–2.5 weave cycles (uniform) and fitted as ``ride validate --segments whole`` does
(:func:`~bike_rig.core.ride.eigen.fit_segment`, the drive shared at the speed by
:func:`~bike_rig.core.ride.eigen.pool_drive`). The truth is the simulator's own loop: its 100 Hz
zero-order-hold discretisation with the assist's gains, ``ln eig(Φ − Γ_δ K) / Δt`` (the
continuous model's ``A − BK`` differs from it by a few % in Re λ). Per speed: clean segments,
the mean and RMS of their z = (x − truth)/σ (Re, Im), the speed mean's z and the pooled χ²/dof of
the clean segments about their weighted mean, and the unweighted mean's error in Re λ (a
segment's σ grows with its fitted decay rate, so the weighted mean leans towards slow draws).

``--signal response`` fits the push's own response (no riding, no sensor noise: the bias of the
cut, the model and the saturation); ``log`` (default) fits the log itself. ``--rider-torque`` and ``--saturation`` set
the simulated rider's steering σ [N m] and the motor's limit [N m].
"""

from __future__ import annotations

import argparse
import math
from collections import Counter
from dataclasses import replace
from typing import Any

import numpy as np
from scipy.signal import cont2discrete

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.ride.eigen import MeasuredEigenvalue, combine_eigenvalues, fit_segment, pool_drive
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.sim.ride_log import SPEED_STEP, SimulatedLog, assist_gains, ride_plan, simulate_raw_log
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import state_space


def _truth(ms: object, v: float, rate: float) -> complex:
    """The weave eigenvalue of the simulator's sampled loop at ``v`` (rounded as it is) [1/s]."""
    key = round(v / SPEED_STEP) * SPEED_STEP
    a, b = (np.asarray(m, dtype=float) for m in state_space(ms.matrices, key, ms.g))  # type: ignore[attr-defined]
    ad, bd, *_ = cont2discrete((a, b, np.eye(4), np.zeros((4, 2))), 1.0 / rate, method="zoh")
    z = np.linalg.eigvals(np.asarray(ad) - np.outer(np.asarray(bd)[:, 1], assist_gains(key)))
    lam = np.log(z.astype(complex)) * rate
    return complex(max(lam, key=lambda x: x.imag))


def _stats(segs: list[MeasuredEigenvalue], truth: complex) -> str:
    clean = [s for s in segs if s.clean]
    if not clean:
        return f"clean 0/{len(segs)}"
    zr = np.array([(s.real - truth.real) / s.real_sigma for s in clean])
    zi = np.array([(s.imag - truth.imag) / s.imag_sigma for s in clean])
    (c,) = combine_eigenvalues(clean)
    re = np.array([s.real for s in clean])
    im = np.array([s.imag for s in clean])
    wr = 1.0 / np.array([s.real_sigma for s in clean]) ** 2
    wi = 1.0 / np.array([s.imag_sigma for s in clean]) ** 2
    dof = max(1, len(clean) - 1)
    chi_r = float(np.sum(wr * (re - np.sum(wr * re) / np.sum(wr)) ** 2)) / dof
    chi_i = float(np.sum(wi * (im - np.sum(wi * im) / np.sum(wi)) ** 2)) / dof
    rr, ri = math.sqrt(float(np.mean(zr**2))), math.sqrt(float(np.mean(zi**2)))
    plain = float(np.mean([s.real for s in clean])) - truth.real
    return (
        f"clean {len(clean):2d}/{len(segs):2d}  z Re {zr.mean():+5.2f}/{rr:4.2f}  Im {zi.mean():+5.2f}/{ri:4.2f}"
        f"  mean Re {c.real:+.3f}±{c.real_sigma:.3f} ({(c.real - truth.real) / c.real_sigma:+4.1f}σ)"
        f" Im {c.imag:.3f}±{c.imag_sigma:.3f} ({(c.imag - truth.imag) / c.imag_sigma:+4.1f}σ)"
        f"  χ²/dof {chi_r:4.2f}/{chi_i:4.2f}  unweighted mean Re − truth {plain:+.3f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=8, help="raw logs per speed (default 8)")
    parser.add_argument("--speeds", default="1.67,3.33,5.0", help="speeds [m/s] (default 1.67,3.33,5.0)")
    parser.add_argument("--parameters", help="bicycle parameter file (default: the shipped Browser)")
    parser.add_argument("--rider", help="rider YAML (default: the paper's rider)")
    parser.add_argument("--model", default="auto", help="segment model (default auto)")
    parser.add_argument("--signal", choices=("log", "response"), default="log")
    parser.add_argument("--rider-torque", type=float, default=None, help="rider's steering σ [N m]")
    parser.add_argument("--saturation", type=float, default=None, help="motor limit [N m]")
    parser.add_argument("--duration", type=float, default=150.0, help="log length [s] (default 150)")
    parser.add_argument("--verbose", action="store_true", help="print each segment")
    parser.add_argument("--found", action="store_true", help="segments found in the log; plain and injected")
    args = parser.parse_args()
    if args.rider:
        from bike_rig.cli.common import rider_from_spec

        rider = rider_from_spec(args.rider)
    else:
        rider = PAPER_RIDER
    bicycle = _parameters(args.parameters or str(config_file("bicycles/browser.yaml")), "centroid")
    ms = canonical_with_sigma(add_rider(bicycle, rider) if rider is not None else bicycle)
    print(f"signal {args.signal}, model {args.model}, {args.seeds} logs × 3 pushes per speed")
    if args.found:
        _found(args, ms)
        return
    for v in (float(x) for x in args.speeds.split(",")):
        segs: list[MeasuredEigenvalue] = []
        truth = complex("nan")
        for s in range(args.seeds):
            log, truth = _simulate(args, ms, v, s)
            cut = np.random.default_rng(s)
            for p in log.pushes:
                stop = p.start + cut.uniform(1.2, 2.5) * 2 * math.pi / truth.imag
                inside = (log.times >= p.start) & (log.times <= stop)
                t = log.times[inside]
                if args.signal == "log":
                    y = log.roll_rate[inside]
                else:
                    y = np.interp(t, log.times[log.times >= p.time][: p.response.size], p.response)
                segs.append(fit_segment(t, y, speed=v, source=f"seed {s}", index=len(segs) + 1, model=args.model))
        segs = pool_drive(segs)
        if args.verbose:
            for m in segs:
                z = (m.real - truth.real) / m.real_sigma
                print(
                    f"  {m.source} #{m.index} {m.n_cycles:.2f} cyc Re {m.real:+.3f}±{m.real_sigma:.3f} (z {z:+.1f})"
                    f" Im {m.imag:.3f}±{m.imag_sigma:.3f} {m.model} {'; '.join(f[:40] for f in m.flags)}"
                )
        print(f"{v:5.2f} m/s truth {truth.real:+.3f}{truth.imag:+.3f}i  {_stats(segs, truth)}", flush=True)


def _simulate(args: argparse.Namespace, ms: Any, v: float, seed: int) -> tuple[SimulatedLog, complex]:
    """Seed ``seed``'s raw log at ``v`` [m/s] with the options' rider and motor, and its weave's truth."""
    rng = np.random.default_rng(100 + seed)
    plan = ride_plan(args.duration, v, 3, rng)
    if args.rider_torque is not None:
        plan = replace(plan, rider_torque=args.rider_torque)
    if args.saturation is not None:
        plan = replace(plan, saturation=args.saturation)
    return simulate_raw_log(ms.matrices, ms.g, plan, rng), _truth(ms, v, plan.rate_hz)


def _flag_codes(segs: list[MeasuredEigenvalue]) -> str:
    codes = Counter(f.split(":")[0] for m in segs for f in m.flags)
    return ", ".join(f"{k} {n}" for k, n in sorted(codes.items())) or "none"


def _found(args: argparse.Namespace, ms: object) -> None:
    """Segments found in each log, fitted plain and with the riding injected (module docstring)."""
    from bike_rig.core.ride.injection import inject_segments
    from bike_rig.core.ride.record import RideRecord
    from bike_rig.core.ride.segment import segment_record
    from bike_rig.offline.rides import fit_segments

    for v in (float(x) for x in args.speeds.split(",")):
        plain: list[MeasuredEigenvalue] = []
        after: list[MeasuredEigenvalue] = []
        truth = complex("nan")
        pushes = found = false = 0
        for s in range(args.seeds):
            log, truth = _simulate(args, ms, v, s)
            record = RideRecord(f"seed {s}", log.times, log.roll_rate, speed=log.wheel_speed)
            segmentation = segment_record(record)
            segments = segmentation.segments
            pooled = pool_drive(fit_segments(record, segments, found=True, model=args.model))
            done = inject_segments(record, segmentation, pooled, args.model)
            pushes += len(log.pushes)
            near = [any(0 <= g.start - p.time <= 2.0 for g in segments) for p in log.pushes]
            found += sum(near)
            false += sum(not any(0 <= g.start - p.time <= 2.0 for p in log.pushes) for g in segments)
            plain += pooled
            after += done
            if args.verbose:
                for a, b in zip(pooled, done, strict=True):
                    print(
                        f"  {a.source} #{a.index} {a.n_cycles:.2f} cyc Re {a.real:+.3f}±{a.real_sigma:.3f} → "
                        f"{b.real:+.3f}±{b.real_sigma:.3f}  Im {a.imag:.3f}±{a.imag_sigma:.3f} → "
                        f"{b.imag:.3f}±{b.imag_sigma:.3f}  {'; '.join(f[:30] for f in b.flags)}"
                    )
        injected = sum(len(b.notes) > len(a.notes) for a, b in zip(plain, after, strict=True))
        corrected = sum(a.real != b.real or a.imag != b.imag for a, b in zip(plain, after, strict=True) if a.valid)
        print(
            f"{v:5.2f} m/s truth {truth.real:+.3f}{truth.imag:+.3f}i  pushes found {found}/{pushes}, "
            f"false segments {false}, injected {injected}/{len(after)}, corrected {corrected}"
        )
        print(f"   plain     {_stats(plain, truth)}  flags: {_flag_codes(plain)}")
        print(f"   injected  {_stats(after, truth)}  flags: {_flag_codes(after)}", flush=True)


if __name__ == "__main__":
    main()
