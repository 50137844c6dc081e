"""Fresh ``bike-rig`` commands as a user runs them: wall time of the whole process.

Each command runs as a new process (the ``bike-rig`` script beside this interpreter, i.e. the
installed copy: ``make venv`` installs the working tree) a few times; the median is printed
against its target, with the machine's load average:

* ``bike-rig params config/bicycles/browser.yaml`` (target ≤ 0.4 s);
* ``bike-rig replay BAG`` of the 39-trial Browser session (as ``bench_replay.py`` writes it;
  target ≤ 1.0 s);
* ``bike-rig report config/bicycles/browser.yaml -o DIR`` (target ≤ 2 s; the figures are drawn
  in forked workers, one per CPU, at most 4: ``bench_report.py`` times it in-process);
* ``bike-rig --help`` and ``python -c pass`` for scale (the interpreter's own start-up).

``python -X importtime`` of a command shows where its start-up goes.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bike_rig.bag.simulated import live_results, simulated_messages, write_simulated_bag
from bike_rig.config.paths import config_file
from bike_rig.core.sim import load_rig, load_true_parameters, simulate_session

REPEAT = 7
SCRIPT = Path(sys.executable).with_name("bike-rig")


def run_median(argv: list[str]) -> float:
    """Median wall time of ``argv`` as a new process (after one unmeasured run), s."""
    env = {**os.environ, "MPLBACKEND": "Agg"}
    times = []
    for k in range(REPEAT + 1):
        t0 = time.perf_counter()
        subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        if k:
            times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> int:
    rig = load_rig(config_file("rig.yaml"))
    bicycle, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    session = simulate_session(truth, rig, 1, bicycle)
    with tempfile.TemporaryDirectory() as tmp:
        bag = write_simulated_bag(Path(tmp) / "session", session, extra=live_results(simulated_messages(session)))
        cases = [
            ("python -c pass", [sys.executable, "-c", "pass"], None),
            ("bike-rig --help", [str(SCRIPT), "--help"], None),
            ("bike-rig params browser.yaml", [str(SCRIPT), "params", str(config_file("bicycles/browser.yaml"))], 0.4),
            ("bike-rig replay BAG (39 trials)", [str(SCRIPT), "replay", str(bag)], 1.0),
            (
                "bike-rig report browser.yaml",
                [str(SCRIPT), "report", str(config_file("bicycles/browser.yaml")), "-o", str(Path(tmp) / "report")],
                2.0,
            ),
        ]
        load = os.getloadavg()
        print(
            f"{SCRIPT} (median of {REPEAT} fresh processes; load average {load[0]:.2f} {load[1]:.2f}, "
            f"{os.cpu_count()} CPUs)"
        )
        ok = True
        for name, argv, target in cases:
            median = run_median(argv)
            verdict = "" if target is None else f"(target <= {target:.1f} s: {'OK' if median <= target else 'MISSED'})"
            ok &= target is None or median <= target
            print(f"  {name:34s} {median:6.2f} s  {verdict}")
    print(f"fresh command start-up: {'OK' if ok else 'MISSED'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
