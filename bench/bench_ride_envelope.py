"""The not_free_decay envelope check on simulated rides: false flags on free decays, pumped decays found.

Prints numbers, asserts nothing. Free decays: the seven conditions of
``bench_ride_scatter.py`` (the Browser with the paper's rider, the balance assist as shipped,
its roll-rate gain doubled, or none; the rider's steering 0.05–0.5 N m; the motor's limit),
``--segments`` segments of 1.2–2.5 cycles at each of two speeds
(:func:`bike_rig.core.ride.ridesim.simulate_segment`), and two growing weaves (shipped gains at
2 and 2.5 m/s, +0.36 and +0.30/s; half the roll-rate gain at 3 and 3.5 m/s, +0.66 and +0.40/s);
printed: how many the envelope check flags ``not_free_decay`` among those no other flag leaves
out. Pumped decays: five decaying
weaves (doubled gain at 2, 2.5 and 3 m/s, rider up to 0.5 N m; shipped gains at 4.5 m/s; at
5.5 m/s with a 2 N m motor), ``--seeds`` segments of each kind:

- **bump**: a second push, 0.3–1 of the first, 0.8–1.2 s into a 2–2.5-cycle segment;
- **dip and bump**: a push half the first that damps the weave at 0.25 of the segment, then one
  that pumps it at 0.55;

each push in the phase that pumps (or damps) the weave (the sign that makes the next
half-cycle's peak larger or smaller), added to the free decay's record (the loop is linear; the
motor's limit is not applied to the pushes' response). A **clear** bump is one whose half-cycle
amplitude after the last push is ≥ 1.3 times the one before it (noise-free record, rider
included). Printed per kind: clear bumps flagged ``not_free_decay``, and left out of the speed
means by any flag. ``--seed-offset`` draws other segments (tune on one set, report on another).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
from bench_ride_scatter import Condition
from bench_ride_scatter import conditions as scatter_conditions  # bench/bench_ride_scatter.py

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.feedback import resolve_feedback
from bike_rig.core.ride.eigen import fit_segment
from bike_rig.core.ride.envelope import half_cycle_amplitudes
from bike_rig.core.ride.ridesim import RideConditions, simulate_log, simulate_segment
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma
from bike_rig.core.whipple import WhippleMatrices

Gains = Callable[[float], np.ndarray | None]


def pumped(
    matrices: WhippleMatrices,
    g: float,
    speed: float,
    gains: np.ndarray | None,
    kind: str,
    conditions: RideConditions,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray, float, int]:
    """A free decay with pushes added: times [s], measured roll rate [rad/s], the bump's ratio, half-cycles."""
    quiet = RideConditions(rate_hz=conditions.rate_hz, noise=0.0, rider_torque=0.0, saturation=math.inf)
    _, response, weave = simulate_log(matrices, g, speed, gains, 10.0, (0.0,), quiet, rng)
    period = 2.0 * math.pi / weave.imag
    if kind == "bump":
        at = float(rng.uniform(0.8, 1.2))
        cycles = max(float(rng.uniform(2.0, 2.5)), (at + float(rng.uniform(0.7, 1.0)) * period) / period)
        plan = [(at, float(rng.uniform(0.3, 1.0)), 1.0)]
    else:
        cycles = float(rng.uniform(2.0, 2.5))
        plan = [(0.25 * cycles * period, 0.5, -1.0), (0.55 * cycles * period, float(rng.uniform(0.4, 1.0)), 1.0)]
    free = simulate_segment(matrices, g, speed, gains, cycles, replace(conditions, noise=0.0), rng)
    t, y = free.times, free.roll_rate.copy()
    dt = 1.0 / conditions.rate_hz
    for at, scale, want in plan:
        i = int(round(at / dt))
        push = np.zeros_like(y)
        push[i:] = scale * response[: y.size - i]
        nxt = slice(i, min(y.size, i + int(0.75 * period / dt)))
        sign = 1.0 if want * np.abs(y + push)[nxt].max() >= want * np.abs(y - push)[nxt].max() else -1.0
        y = y + sign * push
    h = half_cycle_amplitudes(t, y - y.mean(), weave.imag)
    last = t[0] + plan[-1][0]
    before, after = h.amplitudes[h.times < last], h.amplitudes[h.times > last]
    ratio = float(after.max() / before[-1]) if before.size and after.size else math.nan
    return t, y + rng.normal(0.0, conditions.noise, y.size), ratio, h.amplitudes.size


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--segments", type=int, default=30, help="free decays per condition and speed (default 30)")
    parser.add_argument("--seeds", type=int, default=50, help="pumped segments per weave and kind (default 50)")
    parser.add_argument("--seed-offset", type=int, default=0, help="added to every generator's seed (default 0)")
    args = parser.parse_args()
    offset = args.seed_offset
    browser = canonical_with_sigma(
        add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    )
    fb = resolve_feedback(str(config_file("feedback/balance_assist.yaml")))
    assert fb is not None

    def doubled(v: float) -> np.ndarray:
        return fb.gains(v) * np.array([1.0, 1.0, 2.0, 1.0])

    def halved(v: float) -> np.ndarray:
        return fb.gains(v) * np.array([1.0, 1.0, 0.5, 1.0])

    free = scatter_conditions(fb)  # (the scatter table's seven conditions)
    growing: list[Condition] = [
        ("growing: shipped gains, 2 and 2.5 m/s", fb.gains, (2.0, 2.5), RideConditions(rider_torque=0.2)),
        ("growing: ½ roll-rate gain, 3 and 3.5 m/s", halved, (3.0, 3.5), RideConditions(rider_torque=0.2)),
    ]
    m, g = browser.matrices, browser.g
    _free(m, g, "free decays", free, 100 + offset, args.segments)
    print()
    _free(m, g, "growing weaves", growing, 110 + offset, args.segments)
    pumps: list[tuple[str, Gains, float, RideConditions]] = [
        ("×2 gain, 2.0 m/s, rider 0.2 N m", doubled, 2.0, RideConditions(rider_torque=0.2)),
        ("×2 gain, 2.5 m/s, rider 0.2 N m", doubled, 2.5, RideConditions(rider_torque=0.2)),
        ("×2 gain, 3.0 m/s, rider 0.5 N m", doubled, 3.0, RideConditions(rider_torque=0.5)),
        ("shipped gains, 4.5 m/s, rider 0.2 N m", fb.gains, 4.5, RideConditions(rider_torque=0.2)),
        ("shipped gains, 5.5 m/s, motor 2 N m", fb.gains, 5.5, RideConditions(rider_torque=0.2, saturation=2.0)),
    ]
    for kind in ("bump", "dip and bump"):
        print(f"\n{kind + ' (clear: ≥ 1.3×)':48s} {'not_free_decay':>18s} {'left out':>10s}  ≥ 4 half-cycles")
        total = [0, 0, 0, 0, 0]
        for i, (name, gains, v, conditions) in enumerate(pumps):
            rng = np.random.default_rng(200 + i + (50 if kind == "bump" else 0) + offset)
            counts = [0, 0, 0, 0, 0]  # clear, flagged, left out; with ≥ 4 half-cycles: clear, flagged
            for _ in range(args.seeds):
                t, y, ratio, halves = pumped(m, g, v, gains(v), kind.split()[0], conditions, rng)
                if not ratio >= 1.3:
                    continue
                fit = fit_segment(t, y, speed=v)
                hit = any(f.startswith("not_free_decay") for f in fit.flags)
                long = halves >= 4
                counts = [a + b for a, b in zip(counts, (1, hit, not fit.clean, long, long and hit), strict=True)]
            total = [a + b for a, b in zip(total, counts, strict=True)]
            _row(name, counts)
        _row("all", total)


def _free(
    m: WhippleMatrices,
    g: float,
    title: str,
    cases: list[Condition],
    first_seed: int,
    segments: int,
) -> None:
    """Print, per condition, the free segments the envelope check flags among those otherwise clean."""
    print(f"{title:48s} {'flagged / otherwise clean':>26s}")
    total = [0, 0]
    for i, (name, gains, speeds, conditions) in enumerate(cases):
        rng = np.random.default_rng(first_seed + i)
        flagged = kept = 0
        for v in speeds:
            for _ in range(segments):
                s = simulate_segment(m, g, v, gains(v), float(rng.uniform(1.2, 2.5)), conditions, rng)
                fit = fit_segment(s.times, s.roll_rate, speed=v)
                envelope = [f for f in fit.flags if f.startswith("not_free_decay: the envelope")]
                if fit.valid and len(envelope) == len(fit.flags):  # no other flag leaves it out
                    kept += 1
                    flagged += bool(envelope)
        total[0] += flagged
        total[1] += kept
        print(f"{name:48s} {flagged:>5d} / {kept:<5d} ({flagged / max(1, kept):5.1%})", flush=True)
    print(f"{'all':48s} {total[0]:>5d} / {total[1]:<5d} ({total[0] / max(1, total[1]):5.1%})")


def _row(name: str, c: list[int]) -> None:
    n, hit, out, n4, hit4 = c
    print(
        f"{name:48s} {hit:>5d} / {n:<5d} ({hit / max(1, n):4.0%}) {out / max(1, n):8.0%}  "
        f"{hit4:>4d} / {n4:<4d} ({hit4 / max(1, n4):4.0%})",
        flush=True,
    )


if __name__ == "__main__":
    main()
