"""The period fit on the rig simulator's own trials: no ``period_drift`` on clean trials, σ honest.

Every trial kind the simulator makes (viscous linear trials, beating trials, dry friction with a
finite compound swing; short and long records; several bicycles and seeds) is fitted as the
fitter node fits it. Printed per kind: trials, ``period_drift`` flags, the share whose σ was
widened, the share of ±σ covering the true mean period over the window (from the true motion's zero
crossings) and the largest |z| against it, the trials whose σ is below Eq 27's (``period_sigma_white``;
none should be), and Eq 23's least-squares period on every sample of the window (|Δ| ≤ σ), and the
largest |Δ|/σ.

    python bench/bench_period_sim.py [--seeds 20]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from scipy.optimize import least_squares

from bike_rig.config.paths import config_file
from bike_rig.core.period import fit_period
from bike_rig.core.period.oscillation import damped_oscillation, damped_period
from bike_rig.core.sim import TrialSimulator, load_rig, load_true_parameters
from bike_rig.core.sim.session import motion_rate

BICYCLES = ("browser", "rigid", "fisher", "benchmark")
KINDS: dict[str, dict[str, Any]] = {
    "linear 15 s": {"trials": {"duration": 15}},
    "linear 30 s": {"trials": {"duration": 30}},
    "linear 8 s": {"trials": {"duration": 8}},
    "beating 30 s": {"trials": {"duration": 30}, "coupled_swing": {"probability": 1.0}},
    "dry + swing 30 s": {
        "trials": {"duration": 30, "dry_friction": [0.01, 0.05], "finite_swing": True, "amplitude_deg": [4, 13]}
    },
    "dry + swing 15 s": {
        "trials": {"duration": 15, "dry_friction": [0.01, 0.05], "finite_swing": True, "amplitude_deg": [4, 13]}
    },
}


def _rig(kind: dict[str, Any], folder: Path) -> Any:
    data = yaml.safe_load(config_file("rig.yaml").read_text(encoding="utf-8"))
    data["trials"].update({"per_measurement": 1, **kind["trials"]})
    data["coupled_swing"].update({"probability": 0.0, "trials": [], **kind.get("coupled_swing", {})})
    path = folder / "rig.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return load_rig(path)


def _eq23(samples: np.ndarray, rate: float, fit: Any) -> float:
    """Eq 23 fitted to every sample of the fit's window by least squares, s."""
    a, b = fit.window
    t = np.arange(a, b) / rate - fit.t_ref
    y = samples[a:b]
    start = [fit.A, fit.B, fit.C, fit.zeta, fit.omega]
    found = least_squares(lambda p: damped_oscillation(t, *p) - y, start, xtol=1e-12, ftol=1e-12)
    return float(damped_period(found.x[3], found.x[4]))


def _true_mean_period(trial: Any, window: tuple[int, int]) -> float:
    """The true motion's mean period over the fit's window: its phase from the rate's zero crossings, s."""
    rate = trial.sample_rate
    t = np.arange(trial.volts.size) / rate
    y = motion_rate(t, trial.modes, trial.dry_friction, trial.finite_swing)
    k = np.flatnonzero(np.signbit(y[1:]) != np.signbit(y[:-1]))
    crossings = t[k] + y[k] / (y[k] - y[k + 1]) / rate  # (each half cycle is π of phase)
    # one half cycle beyond each end (the window may end after the last crossing: np.interp would clamp)
    crossings = np.concatenate(([2 * crossings[0] - crossings[1]], crossings, [2 * crossings[-1] - crossings[-2]]))
    t0, t1 = (window[0] - 0.5) / rate, (window[1] - 0.5) / rate
    phase = np.interp([t0, t1], crossings, np.pi * np.arange(crossings.size))
    return float(2 * np.pi * (t1 - t0) / (phase[1] - phase[0]))


def main(seeds: int) -> None:
    print(
        f"{'trials':18s} {'n':>5s} {'drift':>6s} {'widened':>8s} {'±σ true':>8s} {'max|z|':>7s} {'σ<Eq27':>7s} "
        f"{'±σ Eq23':>8s} {'max|Δ23|/σ':>10s}"
    )
    with tempfile.TemporaryDirectory() as folder:
        for name, kind in KINDS.items():
            rig = _rig(kind, Path(folder))
            n = drift = widened = below_white = 0
            z_true: list[float] = []
            z_eq23: list[float] = []
            for bike in BICYCLES:
                label, params = load_true_parameters(config_file(f"bicycles/{bike}.yaml"))
                for seed in range(seeds):
                    sim = TrialSimulator.create(params, rig, seed, label)
                    for counter, m in enumerate(sim.plan):
                        trial = sim.simulate(m, counter, 1)
                        fit = fit_period(trial.volts, sample_rate_hz=trial.sample_rate)
                        if not fit.valid:
                            continue
                        n += 1
                        drift += any(f.code.value == "period_drift" for f in fit.flags)
                        widened += fit.sigma_widening > 1.0
                        below_white += fit.period_sigma < fit.period_sigma_white
                        if len(trial.modes) == 1:
                            truth = (
                                _true_mean_period(trial, fit.window)
                                if trial.dry_friction or trial.finite_swing
                                else sim.damped_period(m.key)  # (a constant period: exact)
                            )
                            z_true.append((fit.period - truth) / fit.period_sigma)
                        if len(trial.modes) == 1 and seed < max(1, seeds // 5):  # (the least squares is slow)
                            z_eq23.append((fit.period - _eq23(trial.volts, trial.sample_rate, fit)) / fit.period_sigma)
            cover_true = f"{np.mean(np.abs(z_true) <= 1):.3f}" if z_true else "-"
            cover_eq23 = f"{np.mean(np.abs(z_eq23) <= 1):.3f}" if z_eq23 else "-"
            worst = f"{np.max(np.abs(z_eq23)):.2f}" if z_eq23 else "-"
            worst_true = f"{np.max(np.abs(z_true)):.2f}" if z_true else "-"
            print(
                f"{name:18s} {n:5d} {drift:6d} {widened / n:8.3f} {cover_true:>8s} {worst_true:>7s} {below_white:7d} "
                f"{cover_eq23:>8s} {worst:>10s}"
            )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    main(parser.parse_args().seeds)
