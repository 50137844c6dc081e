"""Three live graphs at once: the highest time scale at which none loses a sample, and what it costs.

Three ``bike-rig run`` graphs of the shipped simulated Browser session (39 trials of 30 s at 1
kHz), each on its own domain, start together on this machine at time scales 100, 200, 400, 800
and the driver's limit 1000. A scale passes when every graph ends with no trial flagged for
missing samples, none without a result, and the parameter set complete. Printed: each scale's
verdict and wall time, the highest that passed, and at the highest the peak resident memory of
every node process (the mean over the three graphs) and its excess over the parameter node's (a
node that holds no gyro history), what the chosen history and QoS cost: the driver holds the
session's gyro history twice (the DDS writer's transient-local history and its own resend
memory, :mod:`bike_rig.pipeline.resend`), the fitter and the recorder a reader's history each.

Run with ``make bench`` (or ``.venv/bin/python bench/bench_concurrent_graphs.py [--max-scale X]``).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bike_rig.ros.env import ros_environment, unique_domain_id

GRAPHS = 3
#: The driver's largest time_scale.
MAX_SCALE = 1000.0
NODES = ("driver", "fitter", "parameter", "model", "recorder")


def _node_memory(domains: set[str]) -> dict[tuple[str, str], int]:
    """Resident memory (kB) of every bike_rig node process on ``domains``: (domain, node) -> kB."""
    out: dict[tuple[str, str], int] = {}
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
            env = dict(e.split(b"=", 1) for e in Path(f"/proc/{pid}/environ").read_bytes().split(b"\0") if b"=" in e)
            status = Path(f"/proc/{pid}/status").read_text()
        except OSError:
            continue
        module = next((c.decode() for c in cmd if c.startswith(b"bike_rig.ros.nodes.")), "")
        domain = env.get(b"ROS_DOMAIN_ID", b"").decode()
        if not module or domain not in domains:
            continue
        rss = next((int(line.split()[1]) for line in status.splitlines() if line.startswith("VmRSS:")), 0)
        out[(domain, module.rsplit(".", 1)[1])] = rss
    return out


def run_three(scale: float, work: Path) -> tuple[bool, float, dict[str, float], list[str]]:
    """Three graphs at ``scale``: (all lossless, wall s, node -> mean peak RSS MB, problems)."""
    problems: list[str] = []
    peak: dict[tuple[str, str], int] = {}
    with contextlib.ExitStack() as stack:
        domains = [stack.enter_context(unique_domain_id()) for _ in range(GRAPHS)]
        runs = []
        t0 = time.perf_counter()
        for i, domain in enumerate(domains):
            out = (work / f"s{scale:g}_g{i}.out").open("w")
            stack.callback(out.close)
            cmd = [
                sys.executable,
                "-m",
                "bike_rig.cli.main",
                "run",
                "--out",
                str(work / f"s{scale:g}_g{i}"),
                "--param",
                f"driver.time_scale={scale:g}",
                "--param",
                "driver.exit_when_done=true",
            ]
            runs.append(subprocess.Popen(cmd, env=ros_environment(domain_id=domain), stdout=out, stderr=out))
        names = {str(d) for d in domains}
        while any(p.poll() is None for p in runs):
            for key, kb in _node_memory(names).items():
                peak[key] = max(peak.get(key, 0), kb)
            time.sleep(0.25)
        wall = time.perf_counter() - t0
    for i, p in enumerate(runs):
        text = (work / f"s{scale:g}_g{i}.out").read_text()
        gaps = sum(1 for line in text.splitlines() if line.startswith("  REDO") and "gap:" in line)
        if p.returncode or gaps or ", 0 without a result" not in text or "parameters: complete" not in text:
            summary = next((line for line in text.splitlines() if "trial(s):" in line), "no summary")
            problems.append(f"graph {i}: exit {p.returncode}, {gaps} trials with missing samples; {summary}")
    memory = {
        n: statistics.mean(kb for (_, name), kb in peak.items() if name == n) / 1024
        for n in NODES
        if any(name == n for _, name in peak)
    }
    return not problems, wall, memory, problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-scale", type=float, default=MAX_SCALE, help="highest time scale tried")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f} ({os.cpu_count()} CPUs)")
    best: tuple[float, dict[str, float]] | None = None
    scales = [s for s in (100.0, 200.0, 400.0, 800.0, MAX_SCALE) if s <= args.max_scale]
    with tempfile.TemporaryDirectory() as tmp:
        for scale in scales:
            ok, wall, memory, problems = run_three(scale, Path(tmp))
            print(f"time scale {scale:6g}: {'lossless' if ok else 'LOST SAMPLES'} ({wall:.1f} s wall)")
            for line in problems:
                print(f"    {line}")
            if not ok:
                break
            best = (scale, memory)
    if best is None:
        print("three concurrent graphs lose samples already at 100x")
        return 1
    print(
        f"highest time scale at which {GRAPHS} concurrent graphs lose nothing: {best[0]:g} (tried "
        f"{', '.join(f'{s:g}' for s in scales)})"
    )
    print("peak resident memory per node there (mean of the graphs; + over the parameter node):")
    base = best[1].get("parameter", 0.0)
    for name, mb in best[1].items():
        print(f"  {name:10s} {mb:7.1f} MB  {mb - base:+7.1f} MB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
