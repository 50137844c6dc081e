"""Deterministic sample messages of every bike_rig type, and comparison helpers.

The messages are built with the bag typestore (no rclpy); the helpers compare messages read back.
"""

from __future__ import annotations

import array
from typing import Any

import numpy as np

from bike_rig.bag.typestore import new_message, rig_typestore
from bike_rig.config.topics import GYRO, TOPICS

_INTS = {"int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64", "byte", "char"}
_FLOATS = {"float32", "float64"}
_NUMPY = {
    "float64": np.float64,
    "float32": np.float32,
    "uint8": np.uint8,
    "int32": np.int32,
    "uint32": np.uint32,
    "int64": np.int64,
    "uint64": np.uint64,
    "uint16": np.uint16,
    "int16": np.int16,
    "int8": np.int8,
}


def _base(kind: str, seed: int) -> Any:
    if kind == "string":
        return f"s{seed}-é"  # non-ASCII on purpose
    if kind == "bool":
        return bool(seed % 2)
    if kind in _INTS:
        return seed % 200 + 1
    if kind in _FLOATS:
        return seed * 0.001 + 1.0 / 3.0
    raise AssertionError(kind)


def seed_of(topic: str, k: int) -> int:
    """The seed of the k-th message on a topic (the recorder tests' stand-in publishes these)."""
    return [t.name for t in TOPICS].index(topic) * 100_000 + k


def make_message(msgtype: str, seed: int) -> Any:
    """A message of msgtype whose every field is filled from seed (sequences of seed % 5 + 1)."""
    store = rig_typestore()
    _, fields = store.fielddefs[msgtype]
    values: dict[str, Any] = {}
    for i, (name, (nodetype, spec)) in enumerate(fields):
        s = seed * 31 + i
        if nodetype == 1:  # BASE
            values[name] = _base(spec[0], s)
        elif nodetype == 2:  # NAME
            values[name] = make_message(spec, s)
        else:  # ARRAY (3) or SEQUENCE (4)
            (inner_type, inner_spec), length = spec
            n = length if nodetype == 3 else s % 5 + 1
            if inner_type == 1 and inner_spec[0] in _NUMPY:
                values[name] = np.array([_base(inner_spec[0], s + k) for k in range(n)], dtype=_NUMPY[inner_spec[0]])
            elif inner_type == 1:
                values[name] = [_base(inner_spec[0], s + k) for k in range(n)]
            else:
                values[name] = [make_message(inner_spec, s + k) for k in range(n)]
    if msgtype == "builtin_interfaces/msg/Time":
        values["sec"], values["nanosec"] = 1_700_000_000 + seed % 100_000_000, seed * 1000 % 1_000_000_000
    return store.types[msgtype](**values)


def serialize(msg: Any) -> bytes:
    """CDR bytes of a typestore message (with the encapsulation header)."""
    return bytes(rig_typestore().serialize_cdr(msg, msg.__msgtype__))


def as_plain(value: Any) -> Any:
    """A message as nested plain data, for == comparisons."""
    if hasattr(value, "__dataclass_fields__"):
        return {
            k: as_plain(getattr(value, k)) for k in value.__dataclass_fields__ if k != "__msgtype__" and not k.isupper()
        }
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, array.array):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [as_plain(v) for v in value]
    if hasattr(value, "get_fields_and_field_types"):  # an rclpy message
        return {k: as_plain(getattr(value, k)) for k in value.get_fields_and_field_types()}
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


def sample_traffic(per_topic: dict[str, int]) -> list[tuple[str, int, bytes, Any]]:
    """(topic, log_time_ns, cdr, message) for ``per_topic[name]`` messages of each rig topic.

    Interleaved round-robin, log times 1 ms apart.
    """
    out: list[tuple[str, int, bytes, Any]] = []
    types = {t.name: t.type for t in TOPICS}
    t = 1_700_000_000_000_000_000
    remaining = dict(per_topic)
    seed = 0
    while any(remaining.values()):
        for name in list(remaining):
            if remaining[name]:
                msg = make_message(types[name], seed)
                out.append((name, t, serialize(msg), msg))
                remaining[name] -= 1
                seed += 1
                t += 1_000_000
    return out


def gyro_message(frame_id: str, trial_id: str, n: int, m: int, seed: int) -> Any:
    """A GyroBatch with these header frame id, trial id and numbers of rates and raw volts, the rest from ``seed``."""
    rng = np.random.default_rng(seed)
    msg = new_message(GYRO.type, trial_id=trial_id, first_index=seed * 50, sample_rate_hz=1000.0 + seed)
    msg.header.frame_id = frame_id
    msg.header.stamp.sec, msg.header.stamp.nanosec = 1_800_000_000 + seed, seed * 7919 % 1_000_000_000
    msg.rates = rng.normal(size=n)
    msg.raw_volts = rng.normal(size=m)
    return msg
