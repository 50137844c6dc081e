"""Small hand-built bags of rig messages (events and gyro batches) for the bag source and driver tests."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer

from bike_rig.bag.typestore import rig_typestore
from bike_rig.config.topics import GYRO, PERIODS, TRIAL_EVENTS

#: Log time of the first message, ns.
T0 = 1_700_000_000_000_000_000
#: The gyro rate of the recorded batches, Hz.
RATE = 500.0


class BagBuilder:
    """Messages for a test bag, written in the order they are added (log time 10 ms apart)."""

    def __init__(self) -> None:
        self.ts = rig_typestore()
        self.items: list[tuple[str, str, Any]] = []

    def header(self, ns: int) -> Any:
        t = self.ts.types
        stamp = t["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        return t["std_msgs/msg/Header"](stamp=stamp, frame_id="gyro")

    def event(self, kind: int, trial_id: str, ns: int, count: int = 0, key: str = "TcB1") -> None:
        msg = self.ts.types[TRIAL_EVENTS.type](
            header=self.header(ns),
            kind=kind,
            trial_id=trial_id,
            part="frame",
            pendulum="compound",
            orientation=0,
            repeat=1,
            measurement_key=key,
            sample_rate_hz=RATE,
            sample_count=count,
            note="n",
        )
        self.items.append((TRIAL_EVENTS.name, TRIAL_EVENTS.type, msg))

    def batch(self, trial_id: str, first: int, rates: np.ndarray, volts: np.ndarray | None = None) -> None:
        msg = self.ts.types[GYRO.type](
            header=self.header(T0 + round(first * 1e9 / RATE)),
            trial_id=trial_id,
            first_index=first,
            sample_rate_hz=RATE,
            rates=rates,
            raw_volts=np.empty(0) if volts is None else volts,
        )
        self.items.append((GYRO.name, GYRO.type, msg))

    def write(self, path: Path, extra_topic: bool = True) -> Path:
        writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
        with writer:
            conns: dict[str, Any] = {}
            for topic, msgtype, _ in self.items:
                if topic not in conns:
                    conns[topic] = writer.add_connection(topic, msgtype, typestore=self.ts)
            if extra_topic:
                writer.add_connection(PERIODS.name, PERIODS.type, typestore=self.ts)
            for i, (topic, msgtype, msg) in enumerate(self.items):
                writer.write(conns[topic], T0 + i * 10_000_000, self.ts.serialize_cdr(msg, msgtype))
        return path


def recorded_session(tmp_path: Path) -> tuple[Path, np.ndarray, np.ndarray]:
    """A bag of three trials (one begun before the recording, one aborted, a STOP without START); (bag, a, b)."""
    rng = np.random.default_rng(7)
    a, b = rng.standard_normal(120), rng.standard_normal(60)
    volts = 2.5 + b / 3
    bag = BagBuilder()
    bag.batch("t0", 0, a[:10])  # a recording that began mid-trial: no START of t0
    bag.event(0, "t1", T0)
    for first in range(0, 120, 50):
        bag.batch("t1", first, a[first : first + 50])
    bag.event(1, "t1", T0 + round(120 * 1e9 / RATE), 123)  # the driver announced more than recorded
    bag.event(0, "t2", T0 + 10**9, key="TcB1")
    bag.batch("t2", 0, b[:30], volts[:30])
    bag.batch("t2", 30, b[30:], volts[30:])
    bag.event(2, "t2", T0 + 2 * 10**9, 60)
    bag.event(1, "ghost", T0 + 3 * 10**9, 5)  # STOP without START
    return bag.write(tmp_path / "bag"), a, b
