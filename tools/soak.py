"""Soak: a live session on the simulated rig for a long time; every process's memory over time.

``make soak`` (default: one hour at the rig's 1 kHz, real time) or, a short version of the same
checks, ``make soak SOAK_ARGS="--seconds 45 --time-scale 100 --every 2 --min-results 40"``.

It runs ``bike-rig session --plain --json`` (the five nodes and the console, real processes over
DDS on loopback, a domain id of its own) and, like an operator who never stops, records the
plan's trials one after another, over and over (every repeat after the first is a redo). Every
``--every`` seconds it reads each process's resident memory (``VmRSS``); at the end it prints
the table over time and, per process, the memory at the end of the warm-up and at the end, and
the growth between them.

The warm-up is the first ``--warmup`` of the run, and at least until the driver's gyro history
is full (counted from the trials recorded, at most 80 % of the run): the driver keeps the last
``DEFAULT_HISTORY_SAMPLES`` samples (the topic's transient-local history, so a restarted fitter
can re-fit, and its resend memory), which is by design the one memory that grows for a while. The exit status
is 1 when a process of the graph is missing or died, grew by more than ``--max-growth`` percent after the
warm-up, fewer than ``--min-results`` trial results came, or the driver's history never filled (then the
warm-up never ended and the growth says nothing).
"""

from __future__ import annotations

import argparse
import json
import os
import queue
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bike_rig.config.paths import config_file  # noqa: E402
from bike_rig.core.sim import load_rig  # noqa: E402
from bike_rig.pipeline.resend import DEFAULT_HISTORY_SAMPLES  # noqa: E402
from bike_rig.ros.env import ros_environment  # noqa: E402
from bike_rig.session.plan import plan_from_rig  # noqa: E402

BIKE_RIG = Path(sys.executable).parent / "bike-rig"
#: The simulated rig's rate, Hz.
RATE_HZ = 1000.0
#: The processes of ``bike-rig session --plain``, each sampled.
PROCESSES = frozenset({"console", "driver", "fitter", "parameter", "model", "recorder"})


@dataclass
class Soak:
    """What the run saw: memory samples per process, results, errors."""

    names: list[str] = field(default_factory=list)
    samples: list[tuple[float, dict[str, float]]] = field(default_factory=list)
    results: int = 0
    flagged: int = 0
    errors: list[str] = field(default_factory=list)
    t0: float = 0.0
    samples_per_trial: float = 0.0
    history_full_s: float | None = None


def _rss_mb(pid: int) -> float:
    """Resident memory of ``pid``, MB (NaN once it has ended)."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def _pids(folder: Path, timeout_s: float = 60.0) -> dict[str, int]:
    path = folder / "logs" / "pids"
    deadline = time.monotonic() + timeout_s
    while not path.is_file() and time.monotonic() < deadline:
        time.sleep(0.1)
    return {n: int(p) for n, p in (line.split() for line in path.read_text().splitlines() if line)}


def _reader(stream: IO[str], soak: Soak, done: queue.Queue[None]) -> None:
    for line in stream:
        reply = json.loads(line)
        if reply["kind"] == "result":
            soak.results += 1
            soak.flagged += reply.get("state") != "ok"
            if soak.history_full_s is None and soak.results * soak.samples_per_trial >= DEFAULT_HISTORY_SAMPLES:
                soak.history_full_s = time.monotonic() - soak.t0
            done.put(None)
        elif reply["kind"] == "error":
            soak.errors.append(reply["text"])
            if reply.get("command") == "start":
                done.put(None)  # a refused start: go on with the next


def _operator(stdin: IO[str], items: list[str], done: queue.Queue[None], stop: threading.Event) -> None:
    """Start the plan's trials one after another, each once the last one's result is in."""
    k = 0
    while not stop.is_set():
        stdin.write(f"start {items[k % len(items)]}\n")
        stdin.flush()
        k += 1
        while not stop.is_set():
            try:
                done.get(timeout=0.5)
                break
            except queue.Empty:
                continue


def run(seconds: float, time_scale: float, every: float, folder: Path) -> Soak:
    """Run the session for ``seconds`` of wall time, sampling memory every ``every`` s."""
    trials = plan_from_rig(load_rig(config_file("rig.yaml"))).trials
    items = [i.item_id for i in trials]
    argv = [str(BIKE_RIG), "session", "--plain", "--json", "--time-scale", str(time_scale), "--output", str(folder)]
    soak = Soak(samples_per_trial=sum(i.duration_s for i in trials) / len(trials) * RATE_HZ)
    env = ros_environment(os.environ)
    with subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env) as proc:
        assert proc.stdin is not None and proc.stdout is not None
        pids = _pids(folder)
        soak.names = list(pids)
        done: queue.Queue[None] = queue.Queue()
        stop = threading.Event()
        soak.t0 = time.monotonic()
        threading.Thread(target=_reader, args=(proc.stdout, soak, done), daemon=True).start()
        operator = threading.Thread(target=_operator, args=(proc.stdin, items, done, stop), daemon=True)
        operator.start()
        while (t := time.monotonic() - soak.t0) < seconds and proc.poll() is None:
            soak.samples.append((t, {n: _rss_mb(p) for n, p in pids.items()}))
            time.sleep(min(every, max(0.0, seconds - t)))
        soak.samples.append((time.monotonic() - soak.t0, {n: _rss_mb(p) for n, p in pids.items()}))
        stop.set()
        operator.join(5)
        try:
            proc.stdin.write("quit\n")
            proc.stdin.close()
        except OSError:
            pass
        proc.wait(60)
    return soak


@dataclass(frozen=True)
class Growth:
    """One process's memory: at the end of the warm-up, at the end, the largest, MB."""

    name: str
    warm: float
    end: float
    peak: float

    @property
    def percent(self) -> float:
        """Growth after the warm-up, %."""
        return 100.0 * (self.end - self.warm) / self.warm


def growth(soak: Soak, warmup_s: float) -> list[Growth]:
    """Each process's growth after ``warmup_s`` (the sample nearest after it, and the last)."""
    after = [s for s in soak.samples if s[0] >= warmup_s] or soak.samples[-1:]
    out = []
    for n in soak.names:
        peak = max(s[1][n] for s in soak.samples)
        out.append(Growth(n, after[0][1][n], soak.samples[-1][1][n], peak))
    return out


def warmup_seconds(soak: Soak, seconds: float, fraction: float) -> float:
    """The warm-up: ``fraction`` of the run, and at least until the driver's gyro history is full (at most 80 %)."""
    full = soak.history_full_s if soak.history_full_s is not None else seconds
    return min(max(fraction * seconds, full), 0.8 * seconds)


def report(soak: Soak, warm_s: float, seconds: float) -> list[Growth]:
    """Print the table over time and the growth per process; return the growth."""
    full = "not reached" if soak.history_full_s is None else f"{soak.history_full_s:.0f} s"
    print(
        f"soak: {seconds:g} s, {soak.results} trial results ({soak.flagged} flagged), warm-up {warm_s:.0f} s "
        f"(the driver's gyro history of {DEFAULT_HISTORY_SAMPLES} samples full: {full})"
    )
    print("t [s]  " + "  ".join(f"{n:>9s}" for n in soak.names) + "   (RSS, MB)")
    step = max(1, len(soak.samples) // 20)
    for t, rss in soak.samples[::step] + soak.samples[-1:]:
        print(f"{t:6.0f} " + "  ".join(f"{rss[n]:9.1f}" for n in soak.names))
    rows = growth(soak, warm_s)
    print(f"{'process':10s} {'after warm-up':>14s} {'end':>9s} {'peak':>9s} {'growth':>8s}")
    for g in rows:
        print(f"{g.name:10s} {g.warm:11.1f} MB {g.end:6.1f} MB {g.peak:6.1f} MB {g.percent:+7.1f} %")
    for e in soak.errors[:5]:
        print(f"error: {e}")
    return rows


def main(argv: list[str] | None = None) -> int:
    """Run the soak (see the module docstring); 1 when a process died or grew too much."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=3600.0, help="wall time, s (default 3600)")
    p.add_argument("--time-scale", type=float, default=1.0, help="rig seconds per wall second (default 1: 1 kHz)")
    p.add_argument("--every", type=float, default=10.0, help="memory sampling period, s (default 10)")
    p.add_argument("--warmup", type=float, default=0.25, help="warm-up, fraction of the run (default 0.25)")
    p.add_argument("--max-growth", type=float, default=5.0, help="allowed growth after warm-up, %% (default 5)")
    p.add_argument("--min-results", type=int, default=1, help="trial results needed (default 1)")
    p.add_argument("--out", help="session folder (default: a temporary one, removed)")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="bike_rig_soak_") as tmp:
        folder = Path(args.out) if args.out else Path(tmp) / "session"
        soak = run(args.seconds, args.time_scale, args.every, folder)
    warm = warmup_seconds(soak, args.seconds, args.warmup)
    rows = report(soak, warm, args.seconds)
    died = [g.name for g in rows if g.end != g.end]  # NaN: ended before the soak did
    grew = [g.name for g in rows if g.percent > args.max_growth]
    missing = sorted(PROCESSES - set(soak.names))
    short = soak.results < max(1, args.min_results)
    if died or grew or missing or short or soak.history_full_s is None:
        print(
            f"soak: FAILED: died {died or 'none'}, grew more than {args.max_growth:g} %: {grew or 'none'}, "
            f"not sampled: {missing or 'none'}, {soak.results} results (at least {args.min_results} wanted), "
            f"history {'never' if soak.history_full_s is None else 'was'} full"
        )
        return 1
    print(f"soak: ok: {len(rows)} processes, none died, none grew more than {args.max_growth:g} % after warm-up")
    return 0


if __name__ == "__main__":
    sys.exit(main())
