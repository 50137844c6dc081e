"""Whole simulated raw ride logs (roll rate and wheel speed, no torque) segmented push by push."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.ride.eigen import fit_segment
from bike_rig.core.ride.record import RideRecord, read_ride_csv
from bike_rig.core.ride.segment import SegmentOptions, find_kicks, segment_record, speed_transients
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.sim.ride_log import RideLog, SimulatedLog, ride_plan, simulate_raw_log, write_log_csv
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma


@cache
def _bicycle() -> tuple[object, float]:
    ms = canonical_with_sigma(
        add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    )
    return ms.matrices, ms.g


@cache
def _log(speed: float, pushes: int, seed: int, duration: float = 179.0) -> SimulatedLog:
    """One seeded simulated log, simulated once for the file (read-only: the tests share it)."""
    matrices, g = _bicycle()
    rng = np.random.default_rng(seed)
    log = simulate_raw_log(matrices, g, ride_plan(duration, speed, pushes, rng), rng)  # type: ignore[arg-type]
    for a in (log.times, log.roll_rate, log.wheel_speed, log.speed, *(p.response for p in log.pushes)):
        a.flags.writeable = False
    return log


def _record(log: SimulatedLog, wheel: bool = True) -> RideRecord:
    return RideRecord("log", log.times, log.roll_rate, speed=log.wheel_speed if wheel else None)


def test_the_simulated_log_rides_off_and_on_and_jolts_the_wheel_at_each_push() -> None:
    log = _log(5.0, 3, seed=0)
    assert log.times[-1] == pytest.approx(179.0, abs=0.02)
    standing = log.speed == 0.0
    assert np.any(standing) and np.all(log.wheel_speed[standing] == 0.0)  # stops: a standing wheel reads 0
    assert np.max(log.speed) == pytest.approx(5.0, rel=0.05)
    times, _, _ = speed_transients(log.times, log.wheel_speed, SegmentOptions())
    for push in log.pushes:
        assert np.any(np.abs(times - push.time) < 0.2), push  # each push jolts the wheel
        assert 0.5 < push.stop - push.start < 3.0  # a free decay of about 1–2.5 weave cycles
    assert np.all(np.abs(times[:, None] - np.array([p.time for p in log.pushes])).min(axis=1) < 0.3)


def test_each_push_keeps_its_own_response_and_the_level_its_decay_ends_at() -> None:
    """The truth's end: the push's own response's envelope last reaches its level there."""
    from scipy.signal import hilbert

    log = _log(5.0, 3, seed=0)
    for push in log.pushes:
        i = int(np.searchsorted(log.times, push.time))
        response = push.response
        assert response.size > 0 and push.level > 0
        envelope = np.abs(hilbert(np.r_[response, np.zeros(response.size)]))[: response.size]
        last = int(np.flatnonzero(envelope > push.level)[-1])
        assert log.times[i + last] == pytest.approx(push.stop, abs=0.011)
        assert np.max(envelope) > 3.0 * push.level  # a response that stands out of the riding
        before = (log.times >= push.time - 4.0) & (log.times < push.time)
        riding = float(np.sqrt(np.mean(log.roll_rate[before] ** 2)))
        assert push.level == pytest.approx(2.0 * riding, rel=0.3)  # twice the riding's RMS (no push in it)


def test_raw_ride_logs_are_segmented_push_by_push() -> None:
    """Three 179 s logs at 18 km/h: each push found, nothing else, cut near the truth."""
    stops = []
    for seed in (0, 1, 2):
        log = _log(5.0, 3, seed)
        segments = segment_record(_record(log)).segments
        assert len(segments) == len(log.pushes), [(s.start, s.stop_reason) for s in segments]
        for seg, truth in zip(segments, log.pushes, strict=True):
            assert abs(seg.kick.onset - truth.time) < 0.2
            assert "wheel speed" in seg.kick.reason and seg.kick.confirmed
            assert abs(seg.start - truth.start) < 0.3
            assert abs(seg.stop - truth.stop) < 1.0, (seed, seg.stop, truth.stop)  # the bench measures the spread
            assert seg.stop_reason.startswith("free decay ends"), seg.stop_reason
            stops.append(seg.stop - truth.stop)
    assert np.median(np.abs(stops)) < 0.3, stops


@pytest.mark.parametrize("seed", [3, 4])
def test_riding_without_a_push_gives_no_segment(seed: int) -> None:
    """Start-ups, stops, turns and the rider's steering: no segment, so no eigenvalue."""
    log = _log(5.0, 0, seed)
    assert segment_record(_record(log)).segments == ()
    alone = _record(log, wheel=False)  # the roll rate alone: never an unstable "clean" weave from starting off
    for seg in segment_record(alone).segments:
        inside = (alone.times >= seg.start) & (alone.times <= seg.stop)
        m = fit_segment(alone.times[inside], alone.signal[inside], speed=float(np.mean(log.speed[inside])))
        assert not (m.clean and m.real > 0), seg


def test_roll_rate_kicks_of_riding_are_dropped_by_the_wheel_speed() -> None:
    log = _log(5.0, 3, seed=4)
    pushes = np.array([p.time for p in log.pushes])
    alone = find_kicks(_record(log, wheel=False))
    assert len(alone) > len(pushes)  # the roll rate alone also finds the rider's motions
    confirmed = find_kicks(_record(log))
    assert [round(k.onset) for k in confirmed] == [round(k.onset) for k in alone if np.min(abs(pushes - k.onset)) < 0.3]


def test_the_segmentation_keeps_every_kick_with_a_segment_or_without() -> None:
    """The roll rate alone: the rider's motions are kicks without a segment, kept for the riding around them."""
    alone = _record(_log(5.0, 3, seed=4), wheel=False)
    found = segment_record(alone)
    assert list(found.kicks) == find_kicks(alone)
    assert {s.kick for s in found.segments} < set(found.kicks)
    assert found.detrended.shape == alone.signal.shape


def test_a_segment_ends_before_the_riders_next_motion() -> None:
    """A push, then 1.2 s later a turn: the segment ends by the turn, not at any cap."""
    matrices, g = _bicycle()
    rng = np.random.default_rng(5)
    plan = RideLog(40.0, 5.0, starts=(1.0,), turns=(21.2,), pushes=(20.0,), rider_torque=0.05)
    log = simulate_raw_log(matrices, g, plan, rng)  # type: ignore[arg-type]
    (seg,) = segment_record(_record(log)).segments
    assert seg.start == pytest.approx(log.pushes[0].start, abs=0.3)
    assert seg.stop < 21.2 + 0.5, (seg.stop, seg.stop_reason)
    assert seg.stop_reason.startswith("free decay ends")


def test_a_log_csv_keeps_its_wheel_speed(tmp_path: Path) -> None:
    log = _log(5.0, 1, seed=6, duration=60.0)
    path = tmp_path / "log.csv"
    write_log_csv(log, path)
    record = read_ride_csv(path)
    assert record.torque is None and record.speed is not None
    assert record.speed == pytest.approx(log.wheel_speed, abs=1e-5)
    (seg,) = segment_record(record).segments
    assert abs(seg.kick.onset - log.pushes[0].time) < 0.2
    assert record.mean_speed(seg.start, seg.stop) == pytest.approx(5.0, abs=0.05)  # the segment's speed


@pytest.mark.parametrize("fill", [5.0, np.nan])
def test_a_speed_that_never_varies_leaves_the_roll_rate_alone(fill: float) -> None:
    """A logger's constant nominal speed, or a speed topic without messages: kicks as without speed."""
    log = _log(5.0, 1, seed=7, duration=60.0)
    flat = RideRecord("log", log.times, log.roll_rate, speed=np.full(log.times.size, fill))
    assert find_kicks(flat) == find_kicks(_record(log, wheel=False)) != []
