"""Segmentation of whole simulated raw ride logs: pushes found, cut error, false segments.

Prints numbers, asserts nothing. Each log (:func:`bike_rig.core.sim.ride_log.simulate_raw_log`:
Browser with the paper's rider, a speed-scheduled assist, 179 s at 100 Hz, roll rate and wheel
speed, no steer torque; the rider starts from standstill, rides, turns, stops and starts again,
and is pushed sideways while riding straight; :func:`~bike_rig.core.sim.ride_log.ride_plan`)
is segmented by :func:`bike_rig.core.ride.segment.segment_record` and each segment fitted by
:func:`bike_rig.offline.rides.fit_segments`. A push is found when a segment's kick begins
within 0.3 s of it; its cut error is the segment's start and stop less the truth's (the push's
end; where its own response's envelope last exceeds twice the riding's RMS). A false segment
belongs to no push; it must never be clean (a kick only the roll rate shows is flagged
``unconfirmed_kick``, as ``bike-rig ride`` flags it). Each speed is run with the wheel speed and, for
comparison, without it (roll rate alone); and with no pushes at all. ``--jolt`` sets the
pushes' largest wheel-speed jolt (default 0.4 m/s, each push's drawn in [½, 1] of it).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.ride.record import RideRecord
from bike_rig.core.ride.segment import segment_record
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.sim.ride_log import ride_plan, simulate_raw_log
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.offline.rides import fit_segments

#: A segment's kick this close to a push [s] finds it.
FOUND_S = 0.3


def run(
    speed: float, pushes: int, seeds: range, wheel: bool, matrices: object, g: float, jolt: float | None = None
) -> dict[str, float]:
    """The counts over ``seeds`` logs at ``speed`` [m/s] with ``pushes`` pushes each (``jolt``: its largest [m/s])."""
    found = false = false_clean = true_clean = 0
    starts: list[float] = []
    stops: list[float] = []
    seconds = 0.0
    for seed in seeds:
        rng = np.random.default_rng(seed)
        plan = ride_plan(179.0, speed, pushes, rng)
        plan = plan if jolt is None else replace(plan, push_jolt=jolt)
        log = simulate_raw_log(matrices, g, plan, rng)  # type: ignore[arg-type]
        record = RideRecord("log", log.times, log.roll_rate, speed=log.wheel_speed if wheel else None)
        t0 = time.perf_counter()
        segments = segment_record(record).segments
        seconds += time.perf_counter() - t0
        matched = set()
        for seg, fitted in zip(segments, fit_segments(record, segments, found=True, speed=speed), strict=True):
            clean = fitted.clean  # with the flag of a kick only the roll rate shows, as ``bike-rig ride`` adds it
            hits = [k for k, p in enumerate(log.pushes) if abs(seg.kick.onset - p.time) <= FOUND_S]
            if hits and hits[0] not in matched:
                matched.add(hits[0])
                truth = log.pushes[hits[0]]
                starts.append(seg.start - truth.start)
                stops.append(seg.stop - truth.stop)
                true_clean += clean
            else:
                false += 1
                false_clean += clean
        found += len(matched)
    a, b = np.abs(starts), np.abs(stops)
    return {
        "pushes": float(pushes * len(seeds)),
        "found": float(found),
        "clean": float(true_clean),
        "false": float(false),
        "false_clean": float(false_clean),
        "start_median": float(np.median(starts)) if starts else float("nan"),
        "start_within": float(np.mean(a <= 0.3)) if starts else float("nan"),
        "stop_median": float(np.median(stops)) if stops else float("nan"),
        "stop_abs50": float(np.median(b)) if stops else float("nan"),
        "stop_abs90": float(np.percentile(b, 90)) if stops else float("nan"),
        "stop_within": float(np.mean(b <= 0.3)) if stops else float("nan"),
        "seconds": seconds / len(seeds),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=20, help="logs per row (default 20)")
    parser.add_argument("--speeds", type=float, nargs="+", default=[5.0, 1.67, 2.5, 3.33, 4.17])
    parser.add_argument("--jolt", type=float, help="the pushes' largest wheel jolt, m/s (default: the simulation's)")
    args = parser.parse_args()
    ps = add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    ms = canonical_with_sigma(ps)
    seeds = range(args.seeds)
    print(f"{args.seeds} simulated 179 s logs per row; start, stop: segment less truth [s] (median; |·| median, p90)")
    head = (
        f"{'km/h':>5} {'input':<16} {'pushes':>6} {'found':>5} {'clean':>5} {'false':>5} {'f.clean':>7} "
        f"{'start':>6} {'≤0.3 s':>6} {'stop':>6} {'|stop|':>6} {'p90':>5} {'≤0.3 s':>6} {'s/log':>6}"
    )
    print(head)
    rows = [(v, 3, w) for v in args.speeds for w in (True, False)] + [(args.speeds[0], 0, True)]
    for v, n, wheel in rows:
        r = run(v, n, seeds, wheel, ms.matrices, ms.g, args.jolt)
        name = ("roll+wheel" if wheel else "roll only") + ("" if n else ", no push")
        print(
            f"{3.6 * v:5.1f} {name:<16} {r['pushes']:6.0f} {r['found']:5.0f} {r['clean']:5.0f} {r['false']:5.0f} "
            f"{r['false_clean']:7.0f} {r['start_median']:+6.2f} {100 * r['start_within']:5.0f}% "
            f"{r['stop_median']:+6.2f} {r['stop_abs50']:6.2f} {r['stop_abs90']:5.2f} {100 * r['stop_within']:5.0f}% "
            f"{r['seconds']:6.2f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
