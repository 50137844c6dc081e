"""The bag source replays a bag's recorded trial events and samples.

A rosbag2 MCAP bag written here (rosbags, our typestore) is replayed as the recorded trial events
and samples, in recording order and paced by recording time.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer

from bike_rig.bag.typestore import rig_typestore
from bike_rig.sources import (
    RigClock,
    SampleBlock,
    SourceConfigError,
    SourceEvent,
    TrialInfo,
    TrialStarted,
    TrialStopped,
    drain,
    open_source,
)
from bike_rig.sources.bag import BagSource
from bike_rig.topics import GYRO, PERIODS, TRIAL_EVENTS

T0 = 1_700_000_000_000_000_000
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
            header=self.header(ns), kind=kind, trial_id=trial_id, part="frame", pendulum="compound",
            orientation=0, repeat=1, measurement_key=key, sample_rate_hz=RATE, sample_count=count, note="n",
        )  # fmt: skip
        self.items.append((TRIAL_EVENTS.name, TRIAL_EVENTS.type, msg))

    def batch(self, trial_id: str, first: int, rates: np.ndarray, volts: np.ndarray | None = None) -> None:
        msg = self.ts.types[GYRO.type](
            header=self.header(T0 + round(first * 1e9 / RATE)), trial_id=trial_id, first_index=first,
            sample_rate_hz=RATE, rates=rates, raw_volts=np.empty(0) if volts is None else volts,
        )  # fmt: skip
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


def test_replays_the_recorded_trials(tmp_path: Path) -> None:
    path, a, b = recorded_session(tmp_path)
    source = open_source("bag", bag=str(path), time_scale=1000.0)
    assert isinstance(source, BagSource)
    source.clock = RigClock(None, math.inf)
    events = list(drain(source))
    kinds = [type(e).__name__ for e in events]
    assert kinds == ["TrialStarted", "SampleBlock", "SampleBlock", "SampleBlock", "TrialStopped",
                     "TrialStarted", "SampleBlock", "SampleBlock", "TrialStopped"]  # fmt: skip
    s1, s2 = events[0], events[5]
    assert isinstance(s1, TrialStarted) and isinstance(s2, TrialStarted)
    assert s1.info == TrialInfo("t1", "frame", "compound", 0, 1, "TcB1", RATE, "n") and s1.stamp_ns == T0
    blocks = [e for e in events if isinstance(e, SampleBlock)]
    assert [(x.trial_id, x.first_index) for x in blocks] == [("t1", 0), ("t1", 50), ("t1", 100), ("t2", 0), ("t2", 30)]
    assert np.array_equal(np.concatenate([x.rates for x in blocks[:3]]), a)
    assert np.array_equal(np.concatenate([x.rates for x in blocks[3:]]), b)
    assert blocks[0].raw_volts is None
    assert np.array_equal(np.concatenate([x.raw_volts for x in blocks[3:] if x.raw_volts is not None]), 2.5 + b / 3)
    stop1, stop2 = events[4], events[8]
    assert stop1 == TrialStopped("t1", 123, T0 + round(120 * 1e9 / RATE), aborted=False)
    assert stop2 == TrialStopped("t2", 60, T0 + 2 * 10**9, aborted=True)
    assert source.skipped_batches == 1 and source.finished


class FakeMonotonic:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_paced_by_recording_time(tmp_path: Path) -> None:
    path, _, _ = recorded_session(tmp_path)
    mono = FakeMonotonic()
    source = BagSource(path, RigClock(None, 2.0, monotonic=mono))
    got: list[SourceEvent] = source.poll()  # log time 0: the stray batch only (skipped)
    assert got == []
    mono.now = 0.0151  # 30.2 ms of bag time: messages at 10, 20, 30 ms
    got = source.poll()
    assert [type(e).__name__ for e in got] == ["TrialStarted", "SampleBlock", "SampleBlock"]
    mono.now = 1.0
    rest = source.poll()
    assert isinstance(rest[-1], TrialStopped) and source.finished


def test_bad_bags_are_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(SourceConfigError, match=r"^bag source: parameter 'bag' = '': the bag source needs the path"):
        open_source("bag", {})
    missing = tmp_path / "nowhere"
    with pytest.raises(SourceConfigError, match=rf"^bag source: parameter 'bag' = '{missing}': no such bag"):
        open_source("bag", bag=str(missing))
    notabag = tmp_path / "notabag"
    notabag.mkdir()
    (notabag / "x.txt").write_text("hello")
    with pytest.raises(SourceConfigError, match=r"cannot be read as a rosbag2 bag"):
        open_source("bag", bag=str(notabag))
    only_events = BagBuilder()
    only_events.event(0, "t1", T0)
    path = only_events.write(tmp_path / "events_only", extra_topic=False)
    pattern = r"holds no /bike_rig/gyro topic \(its topics: /bike_rig/trial_events\)"
    with pytest.raises(SourceConfigError, match=pattern):
        open_source("bag", bag=str(path))
