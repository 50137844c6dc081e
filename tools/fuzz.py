#!/usr/bin/env python3
"""The long fuzz campaign of every file reader: seeded mutations of the valid files.

Usage: ``.venv/bin/python tools/fuzz.py [--inputs N] [--seconds S] [--seed N] [--reader NAME]...``

Readers: measurements, parameters, bp-text, rig, graph, rider, yeadon-measurements,
yeadon-configuration, trial-csv, trial-npy, trial-mat,
bag (a small simulated session's bag with its MCAP storage file mutated, read as ``bike-rig bag
info`` reads it) and bag-metadata (the same bag with its metadata.yaml mutated); and physics:
physically impossible but well-formed parameter and measurement files through ``bike-rig params``
and ``model`` (:mod:`test.fuzz.physics`: any exit-0 result that breaks a plausibility rule fails).

Prints, per reader, the inputs tried, clean one-line errors, inputs read (ok), read with a
remark (flags), crashes, hangs, the slowest call, the largest peak memory of a call
(tracemalloc, with ``--trace-memory``; the .mat reader's scipy runs in a child process, whose
memory is not in it) and the process's peak resident set size so far (children included:
every call's memory is below it). Exits 1 on any
crash or hang, listing each with what reproduces it (seed, reader, index:
``test.fuzz.campaign.input_for``).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from test.fuzz.campaign import fuzz_target
from test.fuzz.harness import Tally
from test.fuzz.physics import PhysicsTally, physics_campaign
from test.fuzz.targets import targets


def main(argv: list[str] | None = None) -> int:
    """Run the campaign; returns the exit status."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--inputs", type=int, default=10_000, help="inputs per reader, the valid seeds included (10000)")
    ap.add_argument("--seconds", type=float, default=None, help="stop each reader after this many seconds")
    ap.add_argument("--seed", type=int, default=int(time.time()), help="campaign seed (default: the time)")
    ap.add_argument("--reader", action="append", help="only this reader (repeatable)")
    ap.add_argument("--time-limit", type=float, default=10.0, help="a call longer than this is a hang [s] (10)")
    ap.add_argument(
        "--trace-memory",
        action="store_true",
        help="each call's peak by tracemalloc (several times slower); the peak RSS is always shown",
    )
    args = ap.parse_args(argv)
    print(f"fuzz: seed {args.seed}, {args.inputs} inputs per reader, hang after {args.time_limit:g} s", flush=True)
    failed = 0
    with tempfile.TemporaryDirectory(prefix="bike_rig_fuzz_") as folder:
        work = Path(folder)
        chosen = [t for t in targets(work) if not args.reader or t.name in args.reader]
        if chosen:
            print(Tally.HEADER, "  wall s", flush=True)
        for target in chosen:
            start = time.monotonic()
            tally = fuzz_target(target, work, args.seed, args.inputs, args.seconds, args.time_limit, args.trace_memory)
            print(tally.line(), f"{time.monotonic() - start:8.0f}", flush=True)
            for label, outcome in tally.failures:
                print(f"  {outcome.kind}: seed {args.seed} {label}: {outcome.message}", flush=True)
            failed += len(tally.failures)
        if not args.reader or "physics" in args.reader:
            print(PhysicsTally.HEADER, flush=True)
            physics = physics_campaign(work, args.seed, args.inputs)
            print(physics.line(), flush=True)
            for index, why in physics.failures:
                print(f"  seed {args.seed} physics#{index}: {why}", flush=True)
            failed += len(physics.failures)
    verdict = f"FAILED, {failed} crash(es), hang(s) or violation(s)" if failed else "no crash, no hang, no violation"
    print(f"fuzz: {verdict} (seed {args.seed}, pid {os.getpid()})")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
