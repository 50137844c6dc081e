"""Dropouts in simulated gyro records: the period fit with and without leaving them out.

The rig simulator's trials (the paper's rig: a gyro at 2.5 V through a 12-bit ADC over ±5 V)
get dropouts: stretches of 20 ms to 1 s where the samples read 0 V or an ADC rail, in the
middle, at the start, at the end, three at once, and in the rad/s the acquisition stores.
Printed per case and sample rate: trials, how many are valid, flagged ``poor_fit``, flagged as a
dropout, the share of ±σ covering the true period (single-mode trials) and the largest |z|, over
the valid trials and over the usable ones (no flag but the dropout's); "before" is the same fit
with the dropout check off. Clean trials (also beating, dry friction with a finite swing, an ADC
saturating) must never be flagged as dropouts.

    python bench/bench_period_dropout.py [--seeds 50]
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
import yaml

from bike_rig.config.paths import config_file
from bike_rig.core.period import Flag, FlagCode, PeriodFit, fit_period
from bike_rig.core.sim import TrialSimulator, load_rig, load_true_parameters
from bike_rig.core.sim.gyro import rate_from_volts

BICYCLES = ("benchmark", "browser", "rigid")
RATES = ((1000.0, 30.0), (100.0, 15.0), (2000.0, 8.0))
Dropper = Callable[[np.ndarray, np.random.Generator, float, Any], np.ndarray]


def _stretch(rng: np.random.Generator, n: int, rate: float, where: str) -> tuple[int, int]:
    length = max(2, int(rng.uniform(0.02, 1.0) * rate))
    if where == "start":
        return 0, length
    if where == "end":
        return n - length, n
    a = int(rng.uniform(2.0 * rate, n - 2.0 * rate - length))
    return a, a + length


def _drop(level: str, where: str, count: int = 1) -> Dropper:
    def drop(volts: np.ndarray, rng: np.random.Generator, rate: float, adc: Any) -> np.ndarray:
        out = volts.copy()
        for _ in range(count):
            a, b = _stretch(rng, out.size, rate, where)
            value = {"0 V": 0.0, "low rail": adc.low, "high rail": adc.low + (2**adc.bits - 1) * adc.lsb}[level]
            out[a:b] = value
        return out

    return drop


CASES: dict[str, Dropper | None] = {
    "clean": None,
    "0 V, middle": _drop("0 V", "middle"),
    "low rail, middle": _drop("low rail", "middle"),
    "high rail, middle": _drop("high rail", "middle"),
    "0 V, start": _drop("0 V", "start"),
    "0 V, end": _drop("0 V", "end"),
    "0 V, 3 times": _drop("0 V", "middle", 3),
}


#: Other trials, checked clean only: no dropout may be found in them.
CLEAN_KINDS: dict[str, dict[str, Any]] = {
    "beating": {"coupled_swing": {"probability": 1.0}},
    "dry + swing 4-13 deg": {"trials": {"dry_friction": [0.01, 0.05], "finite_swing": True, "amplitude_deg": [4, 13]}},
    "swing 30-60 deg (ADC saturates)": {"trials": {"amplitude_deg": [30, 60]}},
}


def _rig(folder: Path, rate: float, duration: float, kind: dict[str, Any] | None = None) -> Any:
    data = yaml.safe_load(config_file("rig.yaml").read_text(encoding="utf-8"))
    data["trials"].update({"per_measurement": 1, "duration": duration, **(kind or {}).get("trials", {})})
    data["coupled_swing"].update((kind or {}).get("coupled_swing", {}))
    data["adc"]["sample_rate"] = rate
    path = folder / "rig.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return load_rig(path)


def _is_dropout_flag(flag: Flag) -> bool:
    return flag.code is FlagCode.GAP_FILLED and "dropout" in flag.reason


def _is_dropout(fit: PeriodFit) -> bool:
    """Found: flagged, or noted where it ends before the window (in the lead-in)."""
    noted = any("dropout" in n and "before the window" in n for n in fit.notes)
    return noted or any(_is_dropout_flag(f) for f in fit.flags)


def _fit(samples: np.ndarray, rate: float, check: bool) -> PeriodFit:
    if check:
        return fit_period(samples, sample_rate_hz=rate)
    with mock.patch("bike_rig.core.period.clean.find_dropouts", return_value=([], (np.nan, np.nan))):
        return fit_period(samples, sample_rate_hz=rate)


def _case(rig: Any, drop: Dropper | None, units: str, seeds: int) -> tuple[int, dict[bool, dict[str, Any]]]:
    """Fits of two random trials per bicycle and seed, before (False) and after (True): counts and z."""
    stats: dict[bool, dict[str, Any]] = {
        c: {"valid": 0, "poor": 0, "drop": 0, "clipped": 0, "z": [], "usable": []} for c in (False, True)
    }
    n = 0
    rate = rig.adc.sample_rate
    for bike in BICYCLES:
        label, params = load_true_parameters(config_file(f"bicycles/{bike}.yaml"))
        for seed in range(seeds):
            sim = TrialSimulator.create(params, rig, seed, label)
            rng = np.random.default_rng(seed)
            for counter in rng.choice(len(sim.plan), size=2, replace=False):
                m = sim.plan[int(counter)]
                trial = sim.simulate(m, int(counter), 1)
                volts = trial.volts if drop is None else drop(trial.volts, rng, rate, rig.adc)
                samples = volts if units == "V" else rate_from_volts(volts, rig.gyro)
                n += 1
                for check in (False, True):
                    fit = _fit(samples, rate, check)
                    s = stats[check]
                    s["drop"] += _is_dropout(fit)
                    s["clipped"] += fit.has_flag(FlagCode.CLIPPED)
                    if fit.valid:
                        s["valid"] += 1
                        s["poor"] += fit.has_flag(FlagCode.POOR_FIT)
                        if len(trial.modes) == 1:
                            z = (fit.period - sim.damped_period(m.key)) / fit.period_sigma
                            s["z"].append(z)
                            if all(_is_dropout_flag(f) for f in fit.flags):  # (no other flag: a usable trial)
                                s["usable"].append(z)
    return n, stats


def _cover(z: list[float]) -> tuple[str, str]:
    a = np.abs(z)
    return (f"{np.mean(a <= 1):.2f}", f"{np.max(a):.1f}") if a.size else ("-", "-")


def main(seeds: int) -> None:
    print(
        f"{'case':20s} {'rate':>5s} {'n':>4s} {'valid':>9s} {'poor_fit':>8s} {'dropout':>8s} {'±σ valid':>11s} "
        f"{'max|z|':>10s} {'usable':>9s} {'±σ usable':>11s} {'max|z|':>10s}   (before / after)"
    )
    with tempfile.TemporaryDirectory() as folder:
        for rate, duration in RATES:
            rig = _rig(Path(folder), rate, duration)
            for case, drop in CASES.items():
                for units in ("V", "rad/s"):
                    if units == "rad/s" and case not in ("clean", "0 V, middle"):
                        continue
                    n, stats = _case(rig, drop, units, seeds)
                    before, after = stats[False], stats[True]
                    name = case + ("" if units == "V" else ", rad/s")
                    row = [f"{before[k]}/{after[k]}" for k in ("valid", "poor", "drop")]
                    usable = f"{len(before['usable'])}/{len(after['usable'])}"
                    (c0, m0), (c1, m1) = _cover(before["z"]), _cover(after["z"])
                    (u0, w0), (u1, w1) = _cover(before["usable"]), _cover(after["usable"])
                    print(
                        f"{name:20s} {rate:5.0f} {n:4d} {row[0]:>9s} {row[1]:>8s} {row[2]:>8s} {c0 + '/' + c1:>11s} "
                        f"{m0 + '/' + m1:>10s} {usable:>9s} {u0 + '/' + u1:>11s} {w0 + '/' + w1:>10s}",
                        flush=True,
                    )
        for name, kind in CLEAN_KINDS.items():
            for rate, duration in RATES:
                n, stats = _case(_rig(Path(folder), rate, duration, kind), None, "V", seeds)
                clipped = stats[True]["clipped"]
                print(
                    f"clean {name}, {rate:g} Hz: {stats[True]['drop']} of {n} flagged as dropouts ({clipped} clipped)"
                )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50)
    main(parser.parse_args().seeds)
