"""Period σ on simulated pendulum records with an unexplained late period change: coverage and flags.

The records are those of ``test/core/test_period_mean.py`` (a compound pendulum with dry friction
through a 12-bit rate gyro, its phase known exactly): the issue's fork on a noisy gyro (3 LSB
noise, 10 LSB bias walk) and on a quiet one (1 LSB, 3 LSB), clean or with the period changing
linearly from a time to the record's end by ΔT; also records of other lengths, and Eq 23's own
records (viscous, constant period). Printed per case:

* ``±σ``: the share of records whose ±σ covers the true mean period over the window;
* ``±σ clean``: the same over the records without ``period_drift`` (a flagged record is sent to be
  redone, its σ need not cover); ``flagged``: the share flagged ``period_drift``;
* ``σ/σ27``: the median and the mean of σ over Eq 27's white σ;
* ``ends ±σ``: the share whose ends' mean period (``ends_period`` ± ``ends_period_sigma``)
  covers the true mean period (of the records that have it);
* ``T₀ ±σ``: with the option ``small_swing_period``, the share whose ±σ covers the true small-swing
  period (swinging cases only; the first ``--small`` seeds).

Then the false-flag rate of ``period_drift`` on ``--clean-seeds`` clean records of each kind.

    python bench/bench_period_late.py [--seeds 200] [--clean-seeds 500] [--small 100]

Runs on the code it imports: pointing PYTHONPATH at another checkout measures that one (the
small-swing column needs the fields both have: ``small_swing_period``, ``period_sigma``).
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from bike_rig.core.period import FlagCode, fit_period
from test.core.test_period_mean import RATE_HZ, T0, swing_record
from test.support.signals import LSB, gyro_trial

QUIET = {"noise": LSB, "drift": 3 * LSB}
CASES: dict[str, dict[str, Any]] = {
    "dry + swing, noisy": {},
    "late −1 ms, noisy": {"late": (23.0, -0.001)},
    "late −2 ms, noisy": {"late": (23.0, -0.002)},
    "late −3 ms, noisy": {"late": (23.0, -0.003)},
    "late +3 ms, noisy": {"late": (23.0, 0.003)},
    "late −7 ms, noisy": {"late": (23.0, -0.007)},
    "dry + swing, quiet": QUIET,
    "late −3 ms, quiet": {"late": (23.0, -0.003), **QUIET},
    "late −7 ms, quiet": {"late": (23.0, -0.007), **QUIET},
    "15 s, late −3 ms from 11.5 s": {"duration": 15.0, "late": (11.5, -0.003)},
    "60 s, half friction, late −3 ms from 52 s": {"duration": 60.0, "loss_per_cycle": 0.016, "late": (52.0, -0.003)},
    "60 s, half friction, clean": {"duration": 60.0, "loss_per_cycle": 0.016},
}


def _swing(kw: dict[str, Any]) -> Callable[[int], tuple[np.ndarray, Callable[[tuple[int, int]], float]]]:
    def make(seed: int) -> tuple[np.ndarray, Callable[[tuple[int, int]], float]]:
        record = swing_record(seed, **kw)
        return record.samples, record.mean_period

    return make


def _viscous(seed: int) -> tuple[np.ndarray, Callable[[tuple[int, int]], float]]:
    return gyro_trial(seed, period=1.5, zeta=0.003).samples, lambda _: 1.5


def _row(name: str, make: Callable[[int], Any], seeds: int, small: int) -> None:
    start = time.perf_counter()
    covered, flagged, ratio, ends = [], [], [], []
    for seed in range(seeds):
        samples, truth = make(seed)
        fit = fit_period(samples, RATE_HZ)
        covered.append(abs(fit.period - truth(fit.window)) <= fit.period_sigma)
        flagged.append(fit.has_flag(FlagCode.PERIOD_DRIFT))
        ratio.append(fit.period_sigma / fit.period_sigma_white)
        if math.isfinite(fit.ends_period):
            ends.append(abs(fit.ends_period - truth(fit.window)) <= fit.ends_period_sigma)
    c, f = np.array(covered), np.array(flagged)
    clean = f"{np.mean(c[~f]):.3f}" if np.any(~f) else "-"
    t0 = "-"
    if small and make is not _viscous:
        fits = [fit_period(make(seed)[0], RATE_HZ, small_swing_period=True) for seed in range(small)]
        swinging = [x for x in fits if x.valid and x.period == x.small_swing_period]
        if swinging:
            t0 = f"{np.mean([abs(x.period - T0) <= x.period_sigma for x in swinging]):.3f}"
    print(
        f"| {name} | {seeds} | {np.mean(c):.3f} | {clean} | {np.mean(f):.3f} | "
        f"{np.median(ratio):.2f} / {np.mean(ratio):.2f} | {np.mean(ends) if ends else math.nan:.3f} | {t0} |  "
        f"({time.perf_counter() - start:.0f} s)"
    )


def _false_flags(name: str, make: Callable[[int], Any], seeds: int) -> None:
    flagged = sum(fit_period(make(seed)[0], RATE_HZ).has_flag(FlagCode.PERIOD_DRIFT) for seed in range(seeds))
    upper = 1 - 0.05 ** (1 / seeds) if flagged == 0 else math.nan
    bound = f" (95 % upper bound {upper:.2g})" if flagged == 0 else ""
    print(f"| {name} | {seeds} | {flagged} | {flagged / seeds:.4f}{bound} |")


def main(seeds: int, clean_seeds: int, small: int) -> None:
    print(
        "| case | n | ±σ covers | ±σ covers, unflagged | flagged | σ/σ27 median / mean | ends ±σ covers "
        "| T₀ ±σ covers |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, kw in CASES.items():
        _row(name, _swing(kw), seeds, small)
    _row("Eq 23 records (viscous, constant period)", _viscous, seeds, 0)
    print()
    print("| clean records | n | flagged period_drift | rate |")
    print("|---|---|---|---|")
    _false_flags("dry + swing, noisy", _swing({}), clean_seeds)
    _false_flags("dry + swing, quiet", _swing(QUIET), clean_seeds)
    _false_flags("Eq 23 records", _viscous, clean_seeds)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=200)
    parser.add_argument("--clean-seeds", type=int, default=500)
    parser.add_argument("--small", type=int, default=100)
    args = parser.parse_args()
    main(args.seeds, args.clean_seeds, args.small)
