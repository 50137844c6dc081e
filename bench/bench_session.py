"""A whole simulated measurement session: generation, and fitting every trial.

Simulates the Browser (paper Table 2, column B, from ``config/bicycles/browser.yaml``) on the
shipped rig (``config/rig.yaml``: 13 periods × 3 trials of 30 s at 1 kHz), then fits every
trial's period (:func:`bike_rig.core.period.fit_period`), combines each period's trials
(:func:`~bike_rig.core.period.combine_periods`) and computes the 25 parameters. Target
(issue): the whole session fitted in ≤ 0.15 s. Prints the median over several seeds.
"""

from __future__ import annotations

import statistics
import sys
import time

from bike_rig.config.paths import config_file
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.period import combine_periods, fit_period
from bike_rig.core.sim import load_rig, load_true_parameters, simulate_session
from bike_rig.core.sim.session import SimulatedSession

TARGET_S = 0.15
REPEAT = 7


def fit_session(session: SimulatedSession) -> dict[str, tuple[float, float]]:
    """Every trial fitted and each period's trials combined: ``{key: (period, sigma)}``."""
    out = {}
    for m in session.plan:
        fits = [fit_period(t.rate, sample_rate_hz=t.sample_rate) for t in session.trials_of(m.key)]
        c = combine_periods(fits)
        out[m.key] = (c.value, c.sigma)
    return out


def main() -> int:
    rig = load_rig(config_file("rig.yaml"))
    bicycle, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    fit_session(simulate_session(truth, rig, 0, bicycle))  # warm-up
    gen, fit, params = [], [], []
    for seed in range(1, REPEAT + 1):
        t0 = time.perf_counter()
        session = simulate_session(truth, rig, seed, bicycle)
        t1 = time.perf_counter()
        periods = fit_session(session)
        t2 = time.perf_counter()
        compute_parameters(session.measurements(periods))
        t3 = time.perf_counter()
        gen.append(t1 - t0)
        fit.append(t2 - t1)
        params.append(t3 - t2)
    samples = sum(len(t.rate) for t in session.trials)
    durations = sorted({len(t.rate) / t.sample_rate for t in session.trials})
    print(
        f"session: {bicycle}, {len(session.trials)} trials of {'/'.join(f'{d:g}' for d in durations)} s "
        f"at {rig.adc.sample_rate:g} Hz ({samples:,} samples); median of {REPEAT} seeds"
    )
    print(f"generation:            {1e3 * statistics.median(gen):8.1f} ms")
    print(f"fit all trials:        {1e3 * statistics.median(fit):8.1f} ms  (target <= {1e3 * TARGET_S:.0f} ms)")
    print(f"25 parameters with σ:  {1e3 * statistics.median(params):8.1f} ms")
    ok = statistics.median(fit) <= TARGET_S
    print(f"fit time per session: {'OK' if ok else 'MISSED'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
