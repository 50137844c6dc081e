"""A seeded mutation campaign over every reader: the suite's bounded one and ``tools/fuzz.py``'s long one.

Input ``i`` of reader ``r`` is ``mutate(seed_j, Random(f"{seed}:{r}:{i}"))``: any failure is
reproduced from the printed seed, the reader's name and the index (:func:`input_for`).
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable
from pathlib import Path

from test.fuzz.harness import Tally, run_reader
from test.fuzz.mutate import mutate
from test.fuzz.targets import Target

__all__ = ["fuzz_target", "input_for"]


def input_for(target: Target, seed: int, index: int) -> bytes:
    """Input ``index`` of ``target``'s campaign with ``seed`` (index < 0: the seeds themselves)."""
    rng = random.Random(f"{seed}:{target.name}:{index}")
    base = rng.choice(target.seeds)
    return mutate(base, rng, target.seeds, target.tokens)


def fuzz_target(
    target: Target,
    workdir: Path,
    seed: int,
    inputs: int,
    seconds: float | None = None,
    time_limit_s: float = 5.0,
    measure_memory: bool = True,
    progress: Callable[[Tally], None] | None = None,
) -> Tally:
    """Run ``inputs`` mutated inputs (the seed files first) through ``target``'s reader.

    Args:
        target: The reader and its seeds.
        workdir: Where inputs are written (one file, rewritten for each).
        seed: The campaign's seed.
        inputs: How many inputs, the valid seeds included.
        seconds: Stop earlier once this much wall time has passed [s] (None: no limit).
        time_limit_s: A call spending more CPU time is a hang [s].
        measure_memory: Measure each call's peak memory.
        progress: Called every 500 inputs with the tally so far.
    """
    tally = Tally(target.name)
    path = workdir / f"input{target.suffix}"
    start = time.monotonic()
    for index in range(inputs):
        if seconds is not None and time.monotonic() - start > seconds:
            break
        k = index - len(target.seeds)
        data = target.seeds[index] if k < 0 else input_for(target, seed, k)
        path.write_bytes(data)
        tally.add(f"{target.name}#{k}", run_reader(target.reader, path, time_limit_s, measure_memory))
        if progress is not None and index % 500 == 499:
            progress(tally)
    return tally
