"""The session report (``bike-rig report``): time to produce it, in process.

* One bicycle: the Browser from its raw measurements (``config/bicycles/browser.yaml``):
  opening the file, the numbers (both rider variants, budget, Monte Carlo check), the 9 model
  figures and the page. Target (issue 5): ≤ 3 s.
* A session bag: a simulated Browser session (39 trials of 12 s at 1 kHz, as the bag tests'
  ``short_session``), replayed offline, with the trial overview and one fit figure per trial
  on top (no target; reported for scale).

The page is written to a temporary directory each time.

Each is the median of a few runs after one warm-up run (imports and caches excluded).
Figures are drawn in forked worker processes, one per CPU (at most 4); the single-process time
is printed too. The bicycle's report is also timed as a user runs it, ``bike-rig report`` in a
fresh process (the installed copy; imports included; target ≤ 2 s).
"""

from __future__ import annotations

import dataclasses
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from timing import median_ms  # bench/timing.py

from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.config.paths import config_file
from bike_rig.core.sim import SimulatedSession, load_rig, load_true_parameters, simulate_session
from bike_rig.report import report_input
from bike_rig.report.figures import default_workers

TARGET_S = 3.0
#: A fresh ``bike-rig report`` of one bicycle, s.
FRESH_TARGET_S = 2.0
REPEAT = 3
REPEAT_BAG = 2
#: Length of each simulated trial, s (as the bag tests' short_session).
TRIAL_S = 12.0


def short_session(seed: int = 7) -> SimulatedSession:
    """The Browser measured on the shipped rig with 12 s trials (39 trials)."""
    name, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    rig = load_rig(config_file("rig.yaml"))
    rig = dataclasses.replace(rig, trials=dataclasses.replace(rig.trials, durations=(TRIAL_S,)))
    return simulate_session(truth, rig, seed=seed, bicycle=name)


def median_s(fn: Callable[[], object], repeat: int) -> float:
    """Median wall time of ``fn`` in s over ``repeat`` calls, after one warm-up call."""
    return median_ms(fn, repeat) / 1e3


def fresh_s(bicycle: str, out: Path, repeat: int) -> float:
    """Median wall time of ``bike-rig report BICYCLE -o OUT`` as a new process, s."""
    argv = [str(Path(sys.executable).with_name("bike-rig")), "report", bicycle, "-o", str(out)]
    env = {**os.environ, "MPLBACKEND": "Agg"}
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> int:
    workers = default_workers()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "report"
        bicycle = str(config_file("bicycles/browser.yaml"))
        last = report_input(bicycle, out)
        one = median_s(lambda: report_input(bicycle, out), REPEAT)
        one_serial = median_s(lambda: report_input(bicycle, out, workers=1), REPEAT)
        size_one = (out / "index.html").stat().st_size
        fresh = fresh_s(bicycle, out, REPEAT)

        bag = write_simulated_bag(Path(tmp) / "bag", short_session())
        last_bag = report_input(bag, out)
        in_bag = median_s(lambda: report_input(bag, out), REPEAT_BAG)
        bag_serial = median_s(lambda: report_input(bag, out, workers=1), REPEAT_BAG)
        size_bag = (out / "index.html").stat().st_size

    print(f"report of one bicycle (Browser, raw measurements; {last.report.drawn} figures, {size_one / 1e6:.1f} MB),")
    print(f"median of {REPEAT}, drawn in {workers} processes:")
    print(f"  report:               {one:6.2f} s  (target <= {TARGET_S:.0f} s)")
    print(f"  in one process:       {one_serial:6.2f} s")
    print(f"  bike-rig report (fresh process): {fresh:6.2f} s  (target <= {FRESH_TARGET_S:.0f} s)")
    print(
        f"report of a session bag ({len(last_bag.report.subject.trials)} trials; {last_bag.report.drawn} figures, "
        f"{size_bag / 1e6:.1f} MB), median of {REPEAT_BAG}:"
    )
    print(f"  report:               {in_bag:6.2f} s  (no target; the target is for one bicycle)")
    print(f"  in one process:       {bag_serial:6.2f} s")
    ok = one <= TARGET_S and fresh <= FRESH_TARGET_S
    print(f"report time for one bicycle: {'OK' if ok else 'MISSED'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
