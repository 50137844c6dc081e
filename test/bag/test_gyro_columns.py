"""Decoding a recording's GyroBatch messages at once gives each trial's batches as one by one."""

from __future__ import annotations

import struct
from typing import Any

import numpy as np

from bike_rig.bag.gyro_cdr import gyro_batch, gyro_columns
from bike_rig.pipeline.acquire import SampleBatch
from test.support.samples import gyro_message, serialize


def gyro_data(frame_id: str, trial_id: str, n: int, m: int, seed: int) -> bytes:
    """The CDR bytes of a GyroBatch with these strings and array lengths, its numbers from ``seed``."""
    return serialize(gyro_message(frame_id, trial_id, n, m, seed))


def plain(b: SampleBatch) -> tuple[Any, ...]:
    """A batch's fields with their types, its arrays as bytes."""
    values = (b.trial_id, b.first_index, b.sample_rate_hz, b.rates.tobytes(), b.raw_volts.tobytes(), b.stamp_ns)
    return (*values, b.frame_id, [type(v).__name__ for v in values], b.rates.dtype.str, b.raw_volts.dtype.str)


def one_by_one(datas: list[bytes]) -> dict[str, list[tuple[Any, ...]]]:
    """Each trial's batches as :func:`gyro_batch` reads them, trials in order of first batch."""
    out: dict[str, list[tuple[Any, ...]]] = {}
    for d in datas:
        b = gyro_batch(d)
        assert b is not None
        out.setdefault(b.trial_id, []).append(plain(b))
    return out


def at_once(datas: list[bytes]) -> dict[str, list[tuple[Any, ...]]]:
    columns = gyro_columns(datas)
    assert columns is not None
    for tid, first, block in zip(columns.trial_ids, columns.first, columns.blocks, strict=True):
        assert block.trial_id == tid
        b = gyro_batch(datas[first])
        assert b is not None and b.trial_id == tid
    return {tid: [plain(b) for b in block] for tid, block in zip(columns.trial_ids, columns.blocks, strict=True)}


def mixed_recording(seed: int) -> list[bytes]:
    """Batches of several trials interleaved, of every layout: strings and arrays of other lengths."""
    rng = np.random.default_rng(seed)
    shapes = [
        ("gyro", "TtB1-1", 50, 50),
        ("gyro", "TtB1-1", 7, 7),
        ("gyro", "TcR12-3", 50, 0),
        ("", "TcR12-3", 0, 0),
        ("other-frame", "t-é", 3, 1),
        ("gyro", "", 50, 50),
        ("g", "TtB1-1", 1, 0),
        ("gyro", "x" * 9, 0, 4),
    ]
    picks = rng.integers(0, len(shapes), size=60)
    return [gyro_data(*shapes[int(p)], seed=k) for k, p in enumerate(picks)]


def test_each_trials_batches_as_one_by_one() -> None:
    for seed in range(5):
        datas = mixed_recording(seed)
        assert at_once(datas) == one_by_one(datas)


def test_one_trial_of_one_layout() -> None:
    datas = [gyro_data("gyro", "TtB1-1", 50, 50, k) for k in range(30)]
    assert at_once(datas) == one_by_one(datas)
    columns = gyro_columns(datas)
    assert columns is not None
    (block,) = columns.blocks
    assert block.bounds.tolist() == list(range(0, 50 * 31, 50))
    assert block.volt_bounds.tolist() == list(range(0, 50 * 31, 50))
    assert np.array_equal(block.first_index, np.arange(30) * 50)


def test_no_messages() -> None:
    columns = gyro_columns([])
    assert columns is not None and columns.blocks == ()


def test_a_message_one_by_one_would_not_read_leaves_them_all_to_it() -> None:
    good = mixed_recording(7)
    sample = gyro_data("gyro", "t1", 5, 0, 1)
    first_at = 4 + 4 + 4 + (4 + 5) + 3 + (4 + 3) + 5  # (header, frame id, trial id, aligned to 8)
    assert struct.unpack_from("<Q", sample, first_at) == (50,)
    bad = [
        b"\x00\x00" + sample[2:],  # big-endian
        sample[:-8],  # cut short
        sample + b"\x00" * 4,  # trailing bytes
        sample[:12] + struct.pack("<I", 200) + sample[16:],  # a string longer than the message
        sample[:3],
        sample[:16] + b"\xff" + sample[17:],  # a frame id that is not UTF-8
        sample[:20] + b"!" + sample[21:],  # a frame id without its NUL
        sample[:first_at] + struct.pack("<Q", 2**63) + sample[first_at + 8 :],  # first_index beyond int64
    ]
    for data in bad:
        assert gyro_batch(data) is None
        assert gyro_columns([*good[:5], data, *good[5:]]) is None
