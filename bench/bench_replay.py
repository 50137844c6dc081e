"""Offline replay of a whole recorded session (targets: ≤ 400 ms warm in-process, ≤ 1.0 s fresh).

Bag → every trial refitted → parameters → weave and capsize speeds, with no ROS runtime.

The bag is a simulated Browser session (paper Table 2, column B) on the shipped rig (13
periods × 3 trials of 30 s at 1 kHz, 50-sample gyro batches: 23,400 batches), written as the
recorder would hold it, together with what the live fitter, parameter and model nodes publish
from it (computed with their own functions). Prints:

* writing the bag (raw CDR → MCAP with zstd chunks): messages/s and MB/s;
* the replay (:func:`bike_rig.offline.replay.replay_bag`, imports warm): median wall and CPU time
  of a few runs and its parts (open + decode every message, fit every trial, assembly + model);
* the floor of reading that bag, timed between the replays so that both see the same load:
  decompressing its chunks (zstd) into one buffer and one copy of its gyro samples, and the
  median ratio of each replay to the floor next to it;
* ``bike-rig replay BAG`` in a fresh process (imports included): median wall and CPU time;
* whether the replay equals the live results (relative 1e-12);
* the replay of the same session written in 8 kB chunks, as the live recorder's 0.5 s flushes
  leave it (no target).

On a busy machine the wall times grow with the load (printed); the CPU times and the ratio to
the floor much less.
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import zstandard
from mcap.reader import make_reader
from mcap.records import ChunkIndex

from bike_rig.bag.simulated import live_results, simulated_messages, write_simulated_bag
from bike_rig.config.paths import config_file
from bike_rig.core.sim import load_rig, load_true_parameters, simulate_session
from bike_rig.offline.replay import replay_bag, replay_session
from bike_rig.offline.session import read_session

TARGET_S = 0.4
#: Target of ``bike-rig replay BAG`` in a fresh process, s.
FRESH_TARGET_S = 1.0
FRESH_REPEAT = 3
#: Uncompressed chunk size of the second bag, bytes: about what 0.5 s of a 1 kHz trial makes.
LIVE_CHUNK_BYTES = 8 << 10
REPEAT = 9
REPO = Path(__file__).resolve().parents[1]


def chunk_indexes(bag: Path) -> list[tuple[Path, ChunkIndex]]:
    """Every chunk index of the bag's MCAP files, with its file."""
    out = []
    for path in sorted(bag.glob("*.mcap")):
        with path.open("rb") as f:
            summary = make_reader(f).get_summary()
        out += [(path, c) for c in (summary.chunk_indexes if summary else [])]
    return out


def read_floor(bag: Path, samples: int) -> Callable[[], float]:
    """What times the floor: decompressing every chunk of the bag into one buffer and copying ``samples`` float64, s."""
    chunks = chunk_indexes(bag)
    raw = []
    for path, c in chunks:
        with path.open("rb") as f:
            f.seek(c.chunk_start_offset + 9 + 40 + len(c.compression))
            raw.append(f.read(c.compressed_size))
    decompressor = zstandard.ZstdDecompressor()
    source = np.random.default_rng(0).normal(size=samples)

    def once() -> float:
        t0 = time.perf_counter()
        out = np.empty(sum(c.uncompressed_size for _, c in chunks), dtype=np.uint8)
        view, at = out.data, 0
        for data, (_, c) in zip(raw, chunks, strict=True):
            reader = decompressor.stream_reader(data)
            end = at + c.uncompressed_size
            while at < end:
                at += reader.readinto(view[at:end])
        np.copy(source)
        return time.perf_counter() - t0

    once()
    return once


def fresh_replay(bag: Path) -> tuple[float, float]:
    """Median wall and CPU time of ``bike-rig replay BAG`` in a fresh process, s."""
    cli = Path(sys.executable).with_name("bike-rig")
    command = [str(cli)] if cli.exists() else [sys.executable, "-c", "from bike_rig.cli.main import main; main()"]
    walls, cpus = [], []
    for _ in range(FRESH_REPEAT):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run([*command, "replay", str(bag)], capture_output=True, check=True, cwd=REPO)
        walls.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return statistics.median(walls), statistics.median(cpus)


def live_recording(bag: Path) -> str:
    """The warm replay of a bag in small chunks, as the live recorder's 0.5 s flushes leave it."""
    n_chunks = len(chunk_indexes(bag))
    replay_bag(bag)
    times = []
    for _ in range(REPEAT):
        t0 = time.perf_counter()
        replay_bag(bag)
        times.append(time.perf_counter() - t0)
    return (
        f"the same session in {LIVE_CHUNK_BYTES >> 10} kB chunks ({n_chunks:,}, as a live recording flushed "
        f"every 0.5 s holds it): replay {1e3 * statistics.median(times):.0f} ms (warm, median of {REPEAT}; "
        "no target)"
    )


def main() -> int:
    rig = load_rig(config_file("rig.yaml"))
    bicycle, truth = load_true_parameters(config_file("bicycles/browser.yaml"))
    session = simulate_session(truth, rig, 1, bicycle)
    extra = live_results(simulated_messages(session))
    n_messages = sum(1 for _ in simulated_messages(session)) + len(extra)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        bag = write_simulated_bag(Path(tmp) / "session", session, extra=extra)
        write_s = time.perf_counter() - t0
        size = sum(f.stat().st_size for f in bag.iterdir())
        samples = sum(len(t.rate) for t in session.trials)
        print(
            f"bag: {bicycle}, {len(session.trials)} trials of 30 s at {rig.adc.sample_rate:g} Hz "
            f"({samples:,} samples), {n_messages:,} messages, {size / 1e6:.1f} MB (zstd chunks)"
        )
        print(
            f"write (serialize + MCAP):  {write_s:6.2f} s   {n_messages / write_s:9,.0f} msg/s  "
            f"{size / 1e6 / write_s:5.1f} MB/s"
        )

        replay_bag(bag)  # warm-up (imports, typestore)
        floor = read_floor(bag, samples)
        totals, cpus, reads, computes, floors = [], [], [], [], []
        result = None
        for _ in range(REPEAT):
            t0, c0 = time.perf_counter(), time.process_time()
            recorded = read_session(bag)
            t1 = time.perf_counter()
            result = replay_session(recorded)
            t2, c2 = time.perf_counter(), time.process_time()
            totals.append(t2 - t0)
            cpus.append(c2 - c0)
            reads.append(t1 - t0)
            computes.append(t2 - t1)
            floors.append(floor())
        assert result is not None and result.stability is not None
        median = statistics.median(totals)
        ratio = statistics.median(t / f for t, f in zip(totals, floors, strict=True))
        load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
        print(
            f"replay (warm, median of {REPEAT}): {1e3 * median:6.0f} ms wall, "
            f"{1e3 * statistics.median(cpus):.0f} ms CPU  (target <= {1e3 * TARGET_S:.0f} ms; load {load})"
        )
        print(
            f"  floor: zstd-decompress the chunks + copy the samples: {1e3 * statistics.median(floors):6.1f} ms "
            f"(replay / floor = {ratio:.1f}, each replay against the floor timed next to it)"
        )
        print(f"  open + decode {recorded.message_count:,} messages: {1e3 * statistics.median(reads):6.0f} ms")
        print(f"  fit {len(result.trials)} trials + assembly + model:  {1e3 * statistics.median(computes):6.0f} ms")
        weave, capsize = result.stability.weave, result.stability.capsize
        assert weave is not None and capsize is not None
        print(
            f"  weave {weave.speed:.4f} ± {weave.sigma:.4f} m/s, capsize {capsize.speed:.4f} ± {capsize.sigma:.4f} m/s"
        )
        live = result.live
        worst = live.worst
        print(
            f"  vs live results: {'identical' if live.identical else 'DIFFERENT'} "
            f"(largest relative difference {worst.max_relative if worst else float('nan'):.1e})"
        )

        fresh_wall, fresh_cpu = fresh_replay(bag)
        print(
            f"fresh 'bike-rig replay BAG' (median of {FRESH_REPEAT}): {fresh_wall:.2f} s wall, "
            f"{fresh_cpu:.2f} s CPU  (target <= {FRESH_TARGET_S:.1f} s)"
        )
        code = (
            "import sys\n"
            "from bike_rig.offline.replay import replay_bag\n"
            f"r = replay_bag({str(bag)!r})\n"
            "print('rclpy' in sys.modules, 'matplotlib' in sys.modules)\n"
        )
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=REPO)
        rclpy_loaded, matplotlib_loaded = out.stdout.split()
        print(f"  replay_bag imports rclpy: {rclpy_loaded}, matplotlib: {matplotlib_loaded}")
        print(
            live_recording(
                write_simulated_bag(Path(tmp) / "flushed", session, extra=extra, chunk_size=LIVE_CHUNK_BYTES)
            )
        )
    ok = median <= TARGET_S and fresh_wall <= FRESH_TARGET_S and live.identical
    print(f"replay of a full session: {'OK' if ok else 'MISSED'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
