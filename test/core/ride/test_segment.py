"""Automatic segmentation of long simulated rides: every kick found, none in quiet stretches."""

from __future__ import annotations

import numpy as np
import pytest

from bike_rig.cli.main import _parameters
from bike_rig.config.paths import config_file
from bike_rig.core.feedback import resolve_feedback
from bike_rig.core.ride.eigen import fit_segment
from bike_rig.core.ride.record import RideRecord
from bike_rig.core.ride.segment import find_kicks, noise_sigma, segment_record
from bike_rig.core.rider import PAPER_RIDER, add_rider
from bike_rig.core.sim.ride import Kick, RideSimulation, SimulatedRide, simulate_ride
from bike_rig.core.uncertainty.matrix_sigma import canonical_with_sigma

#: Kick times of the long ride [s]: irregular, with a quiet stretch from 22 to 40 s.
KICK_TIMES = (2.0, 7.5, 14.0, 19.0, 40.0, 46.5, 52.0)


def _long_ride(speed: float, seed: int) -> SimulatedRide:
    ps = add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    ms = canonical_with_sigma(ps)
    assist = resolve_feedback(str(config_file("feedback/balance_assist.yaml")))
    assert assist is not None
    kicks = tuple(Kick(t, 0.1, 0.0, 5.0 * (-1) ** i) for i, t in enumerate(KICK_TIMES))
    return simulate_ride(ms.matrices, ms.g, RideSimulation(speed, 58.0, kicks=kicks, seed=seed), assist.gains(speed))


@pytest.mark.parametrize("speed", [4.0, 4.5])
def test_torque_kicks_are_all_found_and_none_else(speed: float) -> None:
    ride = _long_ride(speed, seed=7)
    record = RideRecord("sim", ride.times, ride.roll_rate, speed=ride.speed, torque=ride.steer_torque)
    kicks = find_kicks(record)
    assert [round(k.onset, 2) for k in kicks] == pytest.approx(KICK_TIMES, abs=0.015)
    segments = segment_record(record).segments
    assert len(segments) == len(KICK_TIMES)
    for seg, t_kick in zip(segments, KICK_TIMES, strict=True):
        assert seg.start == pytest.approx(t_kick + 0.1 + 0.2, abs=0.02)  # kick end + settle
        assert "steer torque" in seg.start_reason
        assert seg.stop_reason  # a reason for every end
    # the segment before the quiet stretch ends at the longest length, the quiet stretch holds none
    assert not any(22.5 < s.start < 39.9 for s in segments)
    lam = ride.eigenvalues[np.argmax(ride.eigenvalues.imag)]
    for seg in segments:
        inside = (ride.times >= seg.start) & (ride.times <= seg.stop)
        m = fit_segment(ride.times[inside], ride.roll_rate[inside], speed=speed)
        assert m.valid and abs(m.imag - lam.imag) < 5 * m.imag_sigma


def test_roll_rate_kicks_after_a_decay_are_found() -> None:
    ride = _long_ride(4.5, seed=8)  # weave decays at 0.31 1/s: each kick comes after a decay
    record = RideRecord("sim", ride.times, ride.roll_rate)
    kicks = find_kicks(record)
    onsets = np.array([k.onset for k in kicks])
    assert onsets.size == len(KICK_TIMES)
    assert np.all(onsets >= np.array(KICK_TIMES)) and np.all(onsets - np.array(KICK_TIMES) < 0.3)
    assert all("roll rate rose" in k.reason for k in kicks)


def test_noise_only_record_has_no_kicks() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(6000) / 100.0
    record = RideRecord("noise", t, rng.normal(0.0, 0.01, t.size), torque=rng.normal(0.0, 0.05, t.size))
    assert find_kicks(record) == [] and segment_record(record).segments == ()
    assert find_kicks(RideRecord("noise", t, record.signal)) == []


def test_noise_sigma_is_robust_to_the_oscillation() -> None:
    rng = np.random.default_rng(4)
    t = np.arange(3000) / 100.0
    y = 0.3 * np.sin(5.0 * t) + rng.normal(0.0, 0.01, t.size)
    assert noise_sigma(y) == pytest.approx(0.01, rel=0.1)


def _raw_log(rider: float, pushes: tuple[float, ...], seed: int) -> RideRecord:
    """A raw log without a torque channel: the rider steering, the assist motor saturating, lateral pushes."""
    from bike_rig.core.ride.ridesim import RideConditions, simulate_log

    ps = add_rider(_parameters(str(config_file("bicycles/browser.yaml")), "centroid"), PAPER_RIDER)
    ms = canonical_with_sigma(ps)
    assist = resolve_feedback(str(config_file("feedback/balance_assist.yaml")))
    assert assist is not None
    gains = assist.gains(4.2) * np.array([1.0, 1.0, 2.0, 1.0])
    rng = np.random.default_rng(seed)
    t, y, _ = simulate_log(ms.matrices, ms.g, 4.2, gains, 40.0, pushes, RideConditions(rider_torque=rider), rng)
    return RideRecord("log", t, y)


def test_a_raw_log_gives_each_push_a_segment_that_ends_with_its_free_decay() -> None:
    pushes = (3.0, 15.0, 27.0)
    record = _raw_log(0.1, pushes, seed=11)
    segments = segment_record(record).segments
    starts = [s.kick.onset for s in segments]
    for p in pushes:
        assert any(0.0 <= s - p < 0.3 for s in starts), (p, starts)
    for seg in (s for s in segments if any(0.0 <= s.kick.onset - p < 0.3 for p in pushes)):
        assert seg.stop - seg.start < 10.0 and "longest segment" not in seg.stop_reason
        assert seg.stop_reason.startswith(("free decay ends", "lost in noise")), seg.stop_reason
        inside = (record.times >= seg.start) & (record.times <= seg.stop)
        m = fit_segment(record.times[inside], record.signal[inside], speed=4.2)
        assert m.valid and m.real < 0


def test_ordinary_riding_gives_no_clean_eigenvalue() -> None:
    record = _raw_log(0.1, (), seed=12)
    for seg in segment_record(record).segments:
        inside = (record.times >= seg.start) & (record.times <= seg.stop)
        assert not fit_segment(record.times[inside], record.signal[inside], speed=4.2).clean, seg


def test_a_segment_ends_where_its_envelope_stops_explaining_the_record() -> None:
    """A push at 2 s, its free decay, then the rider pumps the weave from 5 s: the segment ends near 5 s."""
    rng = np.random.default_rng(9)
    t = np.arange(0.0, 14.0, 0.01)
    after = np.clip(t - 2.0, 0.0, None)
    pumped = np.clip(t - 5.0, 0.0, 1.5) / 1.5 * 0.25  # the envelope grows again from 5 s
    y = np.where(t >= 2.0, (0.4 * np.exp(-0.3 * after) + pumped) * np.sin(8.6 * after), 0.0)
    record = RideRecord("pumped", t, y + rng.normal(0.0, 0.005, t.size))
    (seg,) = segment_record(record).segments
    assert seg.kick.onset == pytest.approx(2.0, abs=0.3)
    assert seg.stop_reason.startswith("free decay ends") and 4.7 < seg.stop < 5.6, (seg.stop, seg.stop_reason)
