"""The silence watch: a recording trial without samples is reported once per silence."""

from __future__ import annotations

import pytest

from bike_rig.sources.silence import SilenceWatch
from test.support.fakes import ManualClock


def test_each_silence_is_reported_once() -> None:
    mono = ManualClock(100.0)
    watch = SilenceWatch(1.0, monotonic=mono)
    assert watch.due() == []
    watch.started("a")  # requested: no samples yet
    mono.now += 0.999
    assert watch.due() == []
    mono.now += 0.001
    (silence,) = watch.due()
    assert (silence.trial_id, silence.any_samples) == ("a", False) and silence.seconds == pytest.approx(1.0)
    mono.now += 5.0
    assert watch.due() == []  # the same silence: once
    watch.samples("a")
    watch.started("a")  # its START after the samples changes nothing
    mono.now += 0.5
    assert watch.due() == []
    watch.samples("a")
    mono.now += 1.5
    (again,) = watch.due()
    assert (again.trial_id, again.any_samples) == ("a", True) and again.seconds == pytest.approx(1.5)
    watch.stopped("a")
    mono.now += 10.0
    assert watch.due() == [] and watch.watched == ()
    watch.samples("unknown")  # samples of a trial not watched: nothing happens
    assert watch.watched == ()


def test_trials_are_watched_separately() -> None:
    mono = ManualClock(100.0)
    watch = SilenceWatch(0.5, monotonic=mono)
    watch.started("a")
    mono.now += 0.3
    watch.started("b")
    mono.now += 0.3
    assert [s.trial_id for s in watch.due()] == ["a"]
    mono.now += 0.3
    assert [s.trial_id for s in watch.due()] == ["b"]


def test_a_silence_lasts_more_than_zero_seconds() -> None:
    with pytest.raises(ValueError, match="a silence lasts > 0 s"):
        SilenceWatch(0.0)
