"""The sim source in operator mode: each requested trial simulated and streamed on request.

Requests outside the rig's plan are refused with the reason; a requested trial has the
physics' period; START/STOP/ABORT and the samples follow the (fake) clock; ids are unique.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from bike_rig.core.period import fit_period
from bike_rig.core.sim import TrialSimulator, load_rig, load_true_parameters, simulate_session
from bike_rig.pipeline.acquire import sample_stamp_ns
from bike_rig.sources import (
    RigClock,
    SampleBlock,
    SourceConfigError,
    SourceEvent,
    TrialRequest,
    TrialRequestError,
    TrialStarted,
    TrialStopped,
    open_source,
)
from bike_rig.sources.sim_operator import OperatorSimSource, planned_measurement
from test.support.fakes import ManualClock
from test.support.small_sessions import BICYCLE, START_NS, TRIAL_S, operator_source, small_rig

RATE = 1000.0


def samples_of(events: list[SourceEvent], trial_id: str, first: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The rates and raw volts of ``trial_id``'s blocks, checking that they follow one another from ``first``."""
    blocks = [e for e in events if isinstance(e, SampleBlock) and e.trial_id == trial_id]
    assert [b.first_index for b in blocks] == list(first + np.cumsum([0] + [b.rates.size for b in blocks[:-1]]))
    if not blocks:
        return np.empty(0), np.empty(0)
    volts = [b.raw_volts for b in blocks if b.raw_volts is not None]
    return np.concatenate([b.rates for b in blocks]), np.concatenate(volts)


@pytest.fixture
def unpaced(tmp_path: Path) -> OperatorSimSource:
    return operator_source(tmp_path, RigClock(START_NS, math.inf))


@pytest.mark.parametrize(
    ("request_", "pattern"),
    [
        (
            TrialRequest("frame", "torsional", orientation=4),
            r"^orientation 4 is outside the plan: the frame hangs in orientations 1–3 \(rig orientations_deg.frame\)$",
        ),
        (
            TrialRequest("fork", "torsional", orientation=0),
            r"^a fork torsional trial needs its orientation: the fork hangs in orientations 1–3 "
            r"\(rig orientations_deg.fork\)$",
        ),
        (
            TrialRequest("calibration_rod", "compound"),
            r"^the calibration rod is only hung as a torsional pendulum, not as a compound one$",
        ),
        (
            TrialRequest("saddle", "compound"),
            r"^unknown part 'saddle'; the plan's parts are rear_wheel, front_wheel, frame, fork, calibration_rod$",
        ),
        (TrialRequest("frame", "bifilar"), r"^unknown pendulum 'bifilar'; expected compound or torsional$"),
        (
            TrialRequest("rear_wheel", "compound", orientation=2),
            r"^the rear wheel's compound pendulum has no orientation \(give 0, not 2\); only the frame's",
        ),
        (
            TrialRequest("frame", "torsional", orientation=2, measurement_key="TtB3"),
            r"^measurement_key 'TtB3' does not match frame torsional orientation 2 \(its key is TtB2\)$",
        ),
        (
            TrialRequest("fork", "compound", measurement_key="TcB1"),
            r"^measurement_key 'TcB1' does not match fork compound \(its key is TcH1\)$",
        ),
        (TrialRequest("fork", "compound", duration_s=-1.0), r"^duration_s must be > 0 s \(or 0: the rig's 6 s\)"),
        (TrialRequest("fork", "compound", duration_s=math.nan), r"^duration_s must be > 0 s"),
        (TrialRequest("fork", "compound", duration_s=1e5), r"longer than the simulated rig records \(at most 3600 s\)"),
    ],
)
def test_requests_outside_the_plan_are_refused_with_the_reason(
    unpaced: OperatorSimSource, request_: TrialRequest, pattern: str
) -> None:
    with pytest.raises(TrialRequestError, match=pattern):
        unpaced.start_trial(request_)
    assert unpaced.recording is None and unpaced.poll() == [] and unpaced.trials_started == 0


def test_every_planned_measurement_is_accepted_by_its_own_key(unpaced: OperatorSimSource) -> None:
    for m in unpaced.plan:
        request = TrialRequest(m.part, m.pendulum, m.orientation or 0, measurement_key=m.key)
        assert planned_measurement(request, unpaced.plan) == m


def test_plan_order_requests_reproduce_the_simulated_session_bit_for_bit(tmp_path: Path) -> None:
    pause = 0.5
    source = operator_source(tmp_path, RigClock(START_NS, math.inf), pause_s=pause)
    name, truth = load_true_parameters(BICYCLE)
    session = simulate_session(truth, load_rig(small_rig(tmp_path)), 3, name)
    expected_start = START_NS
    for m, reference in zip(session.plan, session.trials, strict=True):
        info = source.start_trial(TrialRequest(m.part, m.pendulum, m.orientation or 0))
        events = source.poll()
        assert source.recording is None and not source.finished
        started, stopped = events[0], events[-1]
        assert isinstance(started, TrialStarted) and started.info == info and started.stamp_ns == expected_start
        assert (info.trial_id, info.measurement_key, info.repeat) == (reference.name, m.key, 1)
        rates, volts = samples_of(events, info.trial_id)
        assert np.array_equal(rates, reference.rate) and np.array_equal(volts, reference.volts)
        assert isinstance(stopped, TrialStopped) and not stopped.aborted
        assert stopped.sample_count == reference.rate.size == round(TRIAL_S * RATE)
        assert stopped.stamp_ns == sample_stamp_ns(started.stamp_ns, stopped.sample_count, RATE)
        expected_start = stopped.stamp_ns + round(pause * 1e9)


@pytest.mark.parametrize(
    ("part", "pendulum", "orientation"),
    [("rear_wheel", "compound", 0), ("fork", "torsional", 2), ("calibration_rod", "torsional", 0)],
)
def test_a_requested_trial_has_the_physics_period(
    unpaced: OperatorSimSource, part: str, pendulum: str, orientation: int
) -> None:
    key = planned_measurement(TrialRequest(part, pendulum, orientation), unpaced.plan).key
    truth = unpaced.simulator.damped_period(key)
    duration = math.ceil(8 * truth)  # 8 periods
    for _ in range(2):  # an earlier trial (another random stream) changes nothing about the period
        info = unpaced.start_trial(TrialRequest(part, pendulum, orientation, duration_s=duration))
        assert info.measurement_key == key
        rates, _ = samples_of(unpaced.poll(), info.trial_id)
        assert rates.size == duration * RATE
        fit = fit_period(rates, sample_rate_hz=RATE)
        assert fit.valid and not fit.flags, fit.flags
        assert abs(fit.period - truth) < 3 * fit.period_sigma, (fit.period, truth, fit.period_sigma)


def test_same_seed_and_counter_give_the_same_trial(tmp_path: Path) -> None:
    a = operator_source(tmp_path / "a", RigClock(START_NS, math.inf))
    b = operator_source(tmp_path / "b", RigClock(START_NS, math.inf))
    other_seed = operator_source(tmp_path / "c", RigClock(START_NS, math.inf), seed=4)
    out = []
    for source in (a, b, other_seed):
        source.start_trial(TrialRequest("fork", "compound", duration_s=1.0))
        out.append(samples_of(source.poll(), "fork_compound_t1")[0])
    assert np.array_equal(out[0], out[1]) and not np.array_equal(out[0], out[2])


def test_paced_by_the_clock_from_the_request_on(tmp_path: Path) -> None:
    mono = ManualClock(100.0)
    source = operator_source(tmp_path, RigClock(START_NS, 20.0, monotonic=mono))
    assert source.poll() == []
    mono.now += 1.0  # 20 s of rig time, nothing requested: nothing streams
    assert source.poll() == []
    info = source.start_trial(TrialRequest("frame", "compound", duration_s=0.5))
    first = source.poll()
    assert isinstance(first[0], TrialStarted) and first[0].stamp_ns == START_NS + 20 * 10**9  # the clock's now
    assert samples_of(first, info.trial_id)[0].size == 1  # sample 0 is due at once
    mono.now += 0.0125  # 0.25 s of rig time (binary fractions: exact sums)
    assert samples_of(source.poll(), info.trial_id, first=1)[0].size == 250
    mono.now += 0.0125 - 2**-30  # just before the end (rig time start + 0.5 s): all samples, no STOP yet
    end = source.poll()
    assert samples_of(end, info.trial_id, first=251)[0].size == 249
    assert not any(isinstance(e, TrialStopped) for e in end)
    mono.now += 2**-29
    stop = source.poll()
    assert len(stop) == 1 and isinstance(stop[0], TrialStopped)
    assert stop[0].sample_count == 500 and stop[0].stamp_ns == START_NS + 20 * 10**9 + 500 * 10**6
    assert source.recording is None and not source.finished


def test_stop_and_abort_end_the_trial_at_the_clock_now(tmp_path: Path) -> None:
    mono = ManualClock(100.0)
    source = operator_source(tmp_path, RigClock(START_NS, 8.0, monotonic=mono))
    with pytest.raises(TrialRequestError, match="^no trial is running$"):
        source.stop_trial()
    info = source.start_trial(TrialRequest("fork", "torsional", 2))  # the rig's duration: 6 s
    with pytest.raises(TrialRequestError, match=r"^trial fork_torsional_o2_t1 is recording; stop or abort it first"):
        source.start_trial(TrialRequest("fork", "torsional", 3))
    mono.now += 0.125  # 1 s of rig time
    with pytest.raises(TrialRequestError, match=r"^trial 'other' is not running \(trial fork_torsional_o2_t1 is\)"):
        source.stop_trial("other")
    stopped = source.stop_trial(info.trial_id)
    events = source.poll()
    assert (stopped.sample_count, stopped.aborted) == (1001, False)
    assert stopped.stamp_ns == sample_stamp_ns(START_NS, 1001, RATE)
    assert samples_of(events, info.trial_id)[0].size == 1001 and events[-1] == stopped
    assert source.recording is None

    mono.now += 0.0625  # 0.5 s of rig time
    again = source.start_trial(TrialRequest("fork", "torsional", 3))
    aborted = source.stop_trial("", abort=True)  # at once: only sample 0
    events = source.poll()
    assert aborted.aborted and aborted.trial_id == again.trial_id and aborted.sample_count == 1
    assert isinstance(events[0], TrialStarted) and events[-1] == aborted
    assert events[0].stamp_ns == START_NS + round(1.5e9)

    short = source.start_trial(TrialRequest("rear_wheel", "torsional", duration_s=0.2))
    mono.now += 1.0  # 8 s of rig time: past its end, not yet polled: it is over, its STOP comes with the next poll
    late = source.stop_trial(abort=True)
    assert (late.trial_id, late.sample_count, late.aborted) == (short.trial_id, 200, False)
    follow = source.start_trial(TrialRequest("rear_wheel", "torsional", duration_s=0.2))  # not "recording"
    kinds = [type(e).__name__ for e in source.poll() if not isinstance(e, SampleBlock)]
    assert kinds == ["TrialStarted", "TrialStopped", "TrialStarted"] and follow.trial_id == "rear_wheel_torsional_t2"
    assert not source.finished


def test_trial_ids_are_never_reused(unpaced: OperatorSimSource) -> None:
    def run(repeat: int = 0, abort: bool = False) -> str:
        info = unpaced.start_trial(TrialRequest("frame", "torsional", 1, repeat=repeat, duration_s=0.01))
        if abort:
            unpaced.stop_trial(info.trial_id, abort=True)
        unpaced.poll()
        return info.trial_id

    stem = "frame_torsional_o1"
    assert [run(), run()] == [f"{stem}_t1", f"{stem}_t2"]
    assert [run(repeat=2), run(repeat=2)] == [f"{stem}_t2_r2", f"{stem}_t2_r3"]  # redos of trial 2
    assert run(abort=True) == f"{stem}_t3"  # an aborted trial keeps its id...
    assert run() == f"{stem}_t4"  # ...which is not given again
    assert run(repeat=7) == f"{stem}_t7"
    assert run() == f"{stem}_t5"


def test_operator_mode_configuration_errors(tmp_path: Path) -> None:
    with pytest.raises(SourceConfigError, match=r"^sim source: parameter 'session' = 'S': the operator mode simulates"):
        open_source("sim", mode="operator", session="S")
    with pytest.raises(SourceConfigError, match=r"^sim source: parameter 'bicycle' = '': the operator mode needs"):
        open_source("sim", mode="operator")
    with pytest.raises(SourceConfigError, match=r"^sim source: parameter 'mode' = 'manual': expected one of plan, "):
        open_source("sim", mode="manual", bicycle=str(BICYCLE))
    with pytest.raises(SourceConfigError, match=r"^sim source: parameter 'rig' = 'norig.yaml': norig.yaml: "):
        open_source("sim", mode="operator", bicycle=str(BICYCLE), rig="norig.yaml")
    source = open_source("sim", mode="operator", bicycle=str(BICYCLE), rig=str(small_rig(tmp_path)), time_scale=50.0)
    assert isinstance(source, OperatorSimSource) and source.supports_requests
    assert source.describe().startswith("sim (operator mode): ") and "time scale 50" in source.describe()
    assert [m.key for m in source.plan] == [
        m.key for m in TrialSimulator.create(load_true_parameters(BICYCLE)[1], load_rig(small_rig(tmp_path)), 0).plan
    ]
    assert isinstance(OperatorSimSource.from_parameters({"bicycle": str(BICYCLE)}), OperatorSimSource)
