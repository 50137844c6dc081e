"""The bag source replays a bag's recorded trial events and samples.

A rosbag2 MCAP bag written here (rosbags, our typestore) is replayed as the recorded trial events
and samples, in recording order and paced by recording time.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

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
from test.support.fakes import ManualClock
from test.support.recorded import RATE, T0, BagBuilder, recorded_session


def test_replays_the_recorded_trials(tmp_path: Path) -> None:
    path, a, b = recorded_session(tmp_path)
    source = open_source("bag", bag=str(path), time_scale=1000.0)
    assert isinstance(source, BagSource)
    source.clock = RigClock(None, math.inf)
    events = list(drain(source))
    kinds = [type(e).__name__ for e in events]
    assert kinds == [
        "TrialStarted",
        "SampleBlock",
        "SampleBlock",
        "SampleBlock",
        "TrialStopped",
        "TrialStarted",
        "SampleBlock",
        "SampleBlock",
        "TrialStopped",
    ]
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


def test_paced_by_recording_time(tmp_path: Path) -> None:
    path, _, _ = recorded_session(tmp_path)
    mono = ManualClock()
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
