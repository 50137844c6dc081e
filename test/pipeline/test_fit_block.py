"""A trial's batches as one SampleBlock fit exactly as the same batches one by one."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
import pytest

from bike_rig.pipeline.acquire import SampleBatch, SampleBlock, TrialEventKind, TrialEventRecord
from bike_rig.pipeline.fit import TrialAccumulator, TrialFitOptions, fit_trial

RATE = 1000.0
N = 6000


def signal(n: int, seed: int) -> np.ndarray:
    t = np.arange(n) / RATE
    rng = np.random.default_rng(seed)
    return 0.3 * np.exp(-0.05 * t) * np.cos(2 * np.pi * 1.7 * t + 0.4) + 1e-3 * rng.normal(size=n)


def block_of(batches: list[SampleBatch]) -> SampleBlock:
    bounds = np.zeros(len(batches) + 1, dtype=np.int64)
    np.cumsum([len(b.rates) for b in batches], out=bounds[1:])
    volt_bounds = np.zeros(len(batches) + 1, dtype=np.int64)
    np.cumsum([len(b.raw_volts) for b in batches], out=volt_bounds[1:])
    frames = tuple(dict.fromkeys(b.frame_id for b in batches))
    return SampleBlock(
        batches[0].trial_id,
        np.array([b.first_index for b in batches], dtype=np.int64),
        np.array([b.sample_rate_hz for b in batches]),
        bounds,
        np.concatenate([b.rates for b in batches]),
        lambda: (volt_bounds, np.concatenate([b.raw_volts for b in batches])),
        np.array([b.stamp_ns for b in batches], dtype=np.int64),
        frames,
        np.array([frames.index(b.frame_id) for b in batches], dtype=np.int64),
    )


def batches_of(samples: np.ndarray, size: int = 50, start: int = 0) -> list[SampleBatch]:
    return [
        SampleBatch("t1", start + a, RATE, samples[a : a + size], samples[a : a + size] * 0.1, 10**18 + a, "gyro")
        for a in range(0, len(samples), size)
    ]


def events(n: int) -> tuple[TrialEventRecord, TrialEventRecord]:
    start = TrialEventRecord(TrialEventKind.START, "t1", "TtB1", "B", "torsional", 1, 1, RATE, 0, 10**18)
    stop = dataclasses.replace(start, kind=TrialEventKind.STOP, sample_count=n, stamp_ns=10**18 + 7)
    return start, stop


def plain(x: Any) -> Any:
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {f.name: plain(getattr(x, f.name)) for f in dataclasses.fields(x)}
    if isinstance(x, np.ndarray):
        return (x.dtype.str, x.shape, x.tobytes())
    if isinstance(x, tuple | list):
        return [plain(v) for v in x]
    if isinstance(x, float) and math.isnan(x):
        return "nan"
    return x


def cases() -> dict[str, list[SampleBatch]]:
    s = signal(N, 1)
    regular = batches_of(s)
    out = {"regular": regular, "from index 100": batches_of(s, start=100), "uneven sizes": batches_of(s, 70)}
    out["duplicate"] = [*regular[:10], regular[4], *regular[10:]]
    out["gap"] = regular[:10] + regular[11:]
    out["out of order"] = [*regular[:5], regular[6], regular[5], *regular[7:]]
    out["overlap"] = [*regular[:5], dataclasses.replace(regular[5], first_index=230), *regular[6:]]
    out["rate change"] = [*regular[:5], dataclasses.replace(regular[5], sample_rate_hz=999.0), *regular[6:]]
    # one NaN object per batch, as decoded from messages
    out["nan rate"] = [dataclasses.replace(b, sample_rate_hz=float("nan")) for b in regular]
    nan = s.copy()
    nan[1234] = math.nan
    out["non-finite sample"] = batches_of(nan)
    out["oversized"] = batches_of(s, 400)
    out["empty batch"] = [*regular[:3], dataclasses.replace(regular[3], rates=s[:0]), *regular[3:]]
    out["one batch"] = regular[:1]
    return out


# NaN rates are not compared: the rate_mismatch reason lists a set of the rates, whose order
# with NaNs depends on the NaN objects (hashed by identity), not on the numbers.
@pytest.mark.parametrize("name", [name for name in cases() if name != "nan rate"])
@pytest.mark.parametrize("announced", [True, False])
def test_a_block_fits_as_its_batches(name: str, announced: bool) -> None:
    batches = cases()[name]
    block = block_of(batches)
    assert [plain(b) for b in block] == [plain(b) for b in batches]
    options = TrialFitOptions(max_batch_samples=300, max_trial_samples=N + 50)
    start, stop = events(N) if announced else (None, None)
    assert plain(fit_trial(block, start, stop, options)) == plain(fit_trial(batches, start, stop, options))


def test_only_regular_blocks_are_taken_at_once() -> None:
    c = cases()
    options = TrialFitOptions(max_batch_samples=300, max_trial_samples=N + 500)
    taken = {name: TrialAccumulator(options).add_block(block_of(b)) for name, b in c.items()}
    assert {name for name, ok in taken.items() if ok} == {
        "regular",
        "from index 100",
        "uneven sizes",
        "non-finite sample",
        "one batch",
    }
    truncated = TrialFitOptions(max_batch_samples=300, max_trial_samples=N - 10)
    assert not TrialAccumulator(truncated).add_block(block_of(c["regular"]))
