"""One pendulum trial (30 s at 1 kHz) → period ± σ: bike_rig against BicycleParameters 1.5.2.

Targets (issue): median ≤ 2 ms per fit, ≥ 25× faster than BicycleParameters'
``bicycleparameters.period.get_period`` on the same samples, periods agreeing within 1σ.

The trial is simulated here: a damped oscillation (T = 1.5 s) seen by a 12-bit rate gyro with
white noise and a drifting bias. bike_rig fits the whole record (its default window: a 1 s
lead-in, then whole cycles); BicycleParameters gets exactly the samples of that window, so both
fit Eq 23 to the same data. Its fit always renders a PNG (``plt.subplots`` ... ``savefig``),
which is not part of the fit: the plotting calls are replaced by no-ops for the timing (its
``plot_osfit`` and the ``plt`` it uses). ``make bench`` puts BicycleParameters on PYTHONPATH
(``.bench-deps``); without it the comparison is skipped.
"""

from __future__ import annotations

import math
import os
import sys
from types import SimpleNamespace
from typing import Any

os.environ.setdefault("MPLBACKEND", "Agg")  # BicycleParameters imports pyplot

import numpy as np
from timing import median_ms  # bench/timing.py

from bike_rig.core.period import fit_period

RATE_HZ = 1000.0
DURATION_S = 30.0
PERIOD_S = 1.5
TARGET_MS = 2.0
TARGET_RATIO = 25.0


def simulated_trial(seed: int = 1, rate_hz: float = RATE_HZ, duration: float = DURATION_S) -> np.ndarray:
    """A 12-bit gyro (±100 °/s) on a pendulum: T = 1.5 s, ζ = 0.003, ~60 LSB swing, drift."""
    rng = np.random.default_rng(seed)
    full_scale = math.radians(100.0)
    lsb = 2 * full_scale / 4096
    t = np.arange(round(duration * rate_hz)) / rate_hz
    omega_d = 2 * math.pi / PERIOD_S
    zeta = 0.003
    omega = omega_d / math.sqrt(1 - zeta**2)
    y = 0.01 + 0.05 * np.exp(-zeta * omega * t) * np.sin(omega_d * t + rng.uniform(0, 2 * math.pi))
    y += lsb * rng.standard_normal(t.size) + np.cumsum(rng.standard_normal(t.size)) * (3 * lsb / math.sqrt(t.size))
    code = np.clip(np.round((y + full_scale) / lsb), 0, 4095)
    return code * lsb - full_scale


def _bicycleparameters_period() -> Any:
    """``bicycleparameters.period`` with its plotting replaced by no-ops, or None."""
    try:
        from bicycleparameters import period as bp_period
    except ImportError:
        return None

    class _Figure:
        def savefig(self, *args: object, **kwargs: object) -> None:
            pass

    bp_period.plot_osfit = lambda *args, **kwargs: None
    bp_period.plt = SimpleNamespace(subplots=lambda *args, **kwargs: (_Figure(), None), close=lambda *args: None)
    return bp_period


def main() -> int:
    samples = simulated_trial()
    ours = fit_period(samples, sample_rate_hz=RATE_HZ)
    t_ours = median_ms(lambda: fit_period(samples, sample_rate_hz=RATE_HZ), 300)
    print(f"trial: {DURATION_S:g} s at {RATE_HZ:g} Hz ({samples.size} samples), true period {PERIOD_S} s")
    print(
        f"bike_rig          : {t_ours:7.3f} ms per fit (median of 300)  T = {ours.period:.6f} s "
        f"± {ours.period_sigma:.1e} (Eq 27 alone ± {ours.period_sigma_white:.1e}), window {ours.window}"
    )
    for rate in (100.0, 10000.0):
        other = simulated_trial(2, rate_hz=rate)
        t_other = median_ms(lambda other=other, rate=rate: fit_period(other, sample_rate_hz=rate), 50)
        print(f"  (30 s at {rate:>5g} Hz: {t_other:7.3f} ms per fit)")
    ok = t_ours <= TARGET_MS
    print(f"target ≤ {TARGET_MS:g} ms per fit: {'OK' if ok else 'MISSED'}")

    bp_period = _bicycleparameters_period()
    if bp_period is None:
        print("bicycleparameters not importable: run via `make bench`; comparison skipped")
        return 0
    start, stop = ours.window
    window = np.ascontiguousarray(samples[start:stop])
    rate = int(RATE_HZ)  # get_period takes an int rate (a float would be taken for a time array)
    theirs = bp_period.get_period(window, rate, os.devnull)
    t_bp = median_ms(lambda: bp_period.get_period(window, rate, os.devnull), 30)
    t_bp_value, t_bp_sigma = float(theirs.nominal_value), float(theirs.std_dev)
    ratio = t_bp / t_ours
    diff = abs(ours.period - t_bp_value)
    print(
        f"BicycleParameters : {t_bp:7.3f} ms per fit (median of 30)   T = {t_bp_value:.6f} s ± {t_bp_sigma:.1e} "
        "(same window, plotting disabled)"
    )
    verdict = "OK" if ratio >= TARGET_RATIO else "MISSED"
    print(f"ratio             : {ratio:7.1f}× (target ≥ {TARGET_RATIO:g}×): {verdict}")
    agree = diff <= ours.period_sigma
    print(
        f"agreement         : |ΔT| = {diff:.1e} s = {diff / ours.period_sigma:.3f} σ (bike_rig σ), "
        f"{diff / t_bp_sigma:.3f} σ (BicycleParameters σ): {'OK' if agree else 'MISSED'}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
