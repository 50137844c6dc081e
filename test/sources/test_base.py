"""The gyro-source interface: backends by name, trial naming, rig time."""

from __future__ import annotations

import math

import pytest

from bike_rig.pipeline.acquire import sample_stamp_ns
from bike_rig.sources import BACKENDS, RigClock, SourceConfigError, TrialRequest, open_source
from bike_rig.sources.base import GyroSource, trial_info_for
from bike_rig.sources.errors import TrialRequestError


def test_every_backend_is_a_gyro_source() -> None:
    from bike_rig.sources import source_class

    assert set(BACKENDS) == {"sim", "can", "bag", "daq"}
    for name in BACKENDS:
        cls = source_class(name)
        assert issubclass(cls, GyroSource) and cls.name == name
        assert cls.supports_requests == (name in ("can", "daq"))


def test_unknown_backend_is_one_clear_error() -> None:
    with pytest.raises(
        SourceConfigError,
        match=r"^parameter 'source' = 'serial': unknown gyro source; "
        r"expected one of sim, can, bag, daq$",
    ):
        open_source("serial")


def test_trial_names_follow_the_simulated_rig() -> None:
    used: set[str] = set()
    a = trial_info_for(TrialRequest("frame", "torsional", orientation=2, duration_s=30.0), 1000.0, used)
    assert (a.trial_id, a.measurement_key, a.orientation, a.repeat) == ("frame_torsional_o2_t1", "TtB2", 2, 1)
    used.add(a.trial_id)
    b = trial_info_for(TrialRequest("frame", "torsional", orientation=2), 1000.0, used)
    assert (b.trial_id, b.repeat) == ("frame_torsional_o2_t2", 2)
    c = trial_info_for(TrialRequest("frame", "torsional", orientation=2, repeat=1), 1000.0, used)
    assert c.trial_id == "frame_torsional_o2_t1_r2"  # the repeat asked for, made unique (a redo)
    d = trial_info_for(TrialRequest("rear_wheel", "compound", orientation=5, measurement_key="X1"), 1000.0, used)
    assert (d.trial_id, d.measurement_key, d.orientation) == ("rear_wheel_compound_t1", "X1", 0)
    with pytest.raises(TrialRequestError, match="duration_s must be > 0 s"):
        trial_info_for(TrialRequest("fork", "compound", duration_s=-1.0), 1000.0, used)
    with pytest.raises(TrialRequestError, match="unknown pendulum 'bifilar'"):
        trial_info_for(TrialRequest("fork", "bifilar"), 1000.0, used)


def test_rig_clock_and_stamps() -> None:
    t = [10.0]
    clock = RigClock(5_000_000_000, 20.0, monotonic=lambda: t[0])
    assert not clock.started
    assert clock.now_ns() == 5_000_000_000 and clock.started
    t[0] += 0.5
    assert clock.now_ns() == 15_000_000_000
    assert RigClock(1, math.inf).now_ns() == math.inf
    wall = RigClock(None, 1.0, wall_ns=lambda: 42)
    assert wall.start_ns == 42
    assert sample_stamp_ns(1_000, 3, 1000.0) == 3_001_000
    assert sample_stamp_ns(0, 1, 3.0) == 333_333_333
    with pytest.raises(ValueError, match="time_scale must be > 0"):
        RigClock(0, 0.0)
