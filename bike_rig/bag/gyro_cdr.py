"""Decode a rig ``GyroBatch`` message from its CDR bytes, with numpy views for the samples.

What rosbags' deserializer gives for the installed definition, field for field and bit for bit,
without a message object per batch. Layout (little-endian CDR after the 4-byte encapsulation
header; offsets from its end, 64-bit values aligned to 8, strings and lengths to 4)::

    int32 sec, uint32 nanosec, string frame_id       (std_msgs/Header)
    string trial_id
    uint64 first_index, float64 sample_rate_hz
    float64[] rates, float64[] raw_volts
"""

from __future__ import annotations

import struct

import numpy as np

from ..pipeline.acquire import NS_PER_S, SampleBatch

__all__ = ["gyro_batch"]

_HEAD = struct.Struct("<iII")
_U32 = struct.Struct("<I")
_FIRST_RATE_N = struct.Struct("<QdI")


def _string(data: bytes, at: int) -> tuple[str, int]:
    """The CDR string at ``at`` (offset in ``data``) and the offset after it."""
    (n,) = _U32.unpack_from(data, at)
    if n < 1 or at + 4 + n > len(data) or data[at + 3 + n] != 0:
        raise ValueError("bad string")
    return data[at + 4 : at + 3 + n].decode(), at + 4 + n


def gyro_batch(data: bytes) -> SampleBatch | None:
    """The batch a little-endian CDR ``GyroBatch`` holds, or None when it is not one this reads exactly."""
    try:
        if data[:2] != b"\x00\x01":
            return None
        sec, nanosec, _ = _HEAD.unpack_from(data, 4)
        frame_id, at = _string(data, 12)
        at = 4 + ((at - 4 + 3) & ~3)
        trial_id, at = _string(data, at)
        at = 4 + ((at - 4 + 7) & ~7)
        first, rate_hz, n = _FIRST_RATE_N.unpack_from(data, at)
        at += 20 + (4 if n else 0)
        rates = np.frombuffer(data, "<f8", n, at)
        at += 8 * n
        (m,) = _U32.unpack_from(data, at)
        at = 4 + (((at + 7) & ~7) if m else at)  # (at - 4 + 4, aligned to 8 when there are volts)
        volts = np.frombuffer(data, "<f8", m, at)
        if len(data) - (at + 8 * m) > 3 or first >= 2**63:
            return None
    except (ValueError, struct.error, UnicodeDecodeError):
        return None
    return SampleBatch(trial_id, first, rate_hz, rates, volts, sec * NS_PER_S + nanosec, frame_id)
