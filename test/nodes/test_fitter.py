"""The fitter: its ROS-free parts, then the node as a real process.

Its ROS-free assembly and fit (``fit_trial``, what the replay uses) and its bookkeeping
(``FitterState``); then the node as a real process: behind a real driver process every trial of
a small simulated session gets a PeriodEstimate identical to ``fit_trial`` on the same samples;
bad input from a test publisher is logged and flagged and the node keeps serving; after a
restart it re-fits the trial in progress from the transient-local history.
"""

from __future__ import annotations

import dataclasses
import json
import math
import struct
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bike_rig import messages
from bike_rig.config.paths import config_file
from bike_rig.config.topics import FIT_DETAILS, GYRO, PERIODS, RESEND_SAMPLES, TRIAL_EVENTS
from bike_rig.core.period import FitOptions, WindowPolicy, fit_period
from bike_rig.pipeline.acquire import SampleBatch, TrialEventKind, TrialEventRecord
from bike_rig.pipeline.fit import TrialFit, TrialFitOptions, fit_trial
from bike_rig.pipeline.fit_details import FitDetails
from bike_rig.pipeline.fit_state import FitterState
from bike_rig.pipeline.resend import SentBatches
from test.support.fakes import ManualClock, RecordingLog
from test.support.probe import STEP_TIMEOUT_S, Probe, msgs, node_command
from test.support.processes import RosProcess
from test.support.small_sessions import small_session

RATE = 1000.0
N = 8000
T0 = 1_700_000_000_000_000_000


# ---------------------------------------------------------------------- ROS-free


def Batch(trial_id: str, first_index: int, rates: np.ndarray, sample_rate_hz: float = RATE) -> SampleBatch:
    return SampleBatch(trial_id, first_index, sample_rate_hz, np.asarray(rates, dtype=np.float64))


def event(kind: int, trial_id: str = "t", count: int = 0, key: str = "TtB1", ns: int = T0) -> TrialEventRecord:
    return TrialEventRecord(TrialEventKind(kind), trial_id, key, sample_rate_hz=RATE, sample_count=count, stamp_ns=ns)


def signal(n: int = N, period: float = 1.0, seed: int = 1) -> np.ndarray:
    t = np.arange(n) / RATE
    rng = np.random.default_rng(seed)
    return 0.05 * np.exp(-0.006 * t) * np.sin(2 * np.pi * t / period + 0.4) + 0.01 + 1e-4 * rng.standard_normal(n)


def batches_of(rates: np.ndarray, trial_id: str = "t", size: int = 50) -> list[SampleBatch]:
    return [Batch(trial_id, a, rates[a : a + size]) for a in range(0, rates.size, size)]


def same(a: float, b: float) -> bool:
    """Identical floats (NaN equals NaN)."""
    return struct.pack("<d", a) == struct.pack("<d", b)


def test_a_clean_trial_is_fit_period_of_its_samples() -> None:
    rates = signal()
    result = fit_trial(batches_of(rates), event(0, count=0), event(1, count=N))
    direct = fit_period(rates, sample_rate_hz=RATE)
    assert result.valid and result.flag_codes == () and result.flag_reasons == ()
    assert same(result.period, direct.period) and same(result.period_sigma, direct.period_sigma)
    assert (result.n_samples, result.n_expected) == (N, N)
    assert result.window == direct.window
    assert result.measurement_key == "TtB1" and result.stamp_ns == T0
    assert abs(result.period - 1.0) < 5 * result.period_sigma


def test_order_and_duplicates_do_not_matter() -> None:
    rates = signal()
    batches = batches_of(rates)
    shuffled = list(batches)
    np.random.default_rng(3).shuffle(shuffled)  # type: ignore[arg-type]
    shuffled += batches[:7]  # duplicates, ignored
    a = fit_trial(batches, event(0), event(1, count=N))
    b = fit_trial(shuffled, event(0), event(1, count=N))
    assert same(a.period, b.period) and a.flag_codes == b.flag_codes == () and b.n_samples == N


def test_gaps_are_flagged_and_fitted_on_the_true_times() -> None:
    rates = signal()
    kept = [b for b in batches_of(rates) if b.first_index not in (1000, 1050, 4000)]
    result = fit_trial(kept, event(0), event(1, count=N + 0))
    assert result.flag_codes[0] == "gap"
    assert "150 samples missing in 2 gap(s): [1000, 1100), [4000, 4050)" in result.flag_reasons[0]
    index = np.concatenate([np.arange(b.first_index, b.first_index + 50) for b in kept])
    direct = fit_period(np.concatenate([b.rates for b in kept]), times=index / RATE)
    assert same(result.period, direct.period) and result.n_samples == N - 150
    lost_end = fit_trial(batches_of(rates)[:-2], event(0), event(1, count=N))
    assert lost_end.flag_codes[0] == "gap" and "[7900, 8000)" in lost_end.flag_reasons[0]


def test_oversized_truncated_and_non_finite() -> None:
    rates = signal()
    options = TrialFitOptions(max_trial_samples=6000, max_batch_samples=100)
    batches = batches_of(rates)
    batches.insert(5, Batch("t", 20_000, np.zeros(500)))
    poisoned = batches[10].rates.copy()
    poisoned[3] = math.nan
    batches[10] = dataclasses.replace(batches[10], rates=poisoned)
    result = fit_trial(batches, event(0), event(1, count=N), options)
    assert result.flag_codes[:2] == ("oversized_batch", "truncated")
    reason = "1 batch(es) larger than max_batch_samples 100 rejected (first: 500 samples at index 20000)"
    assert reason in result.flag_reasons[0]
    assert "2000 samples dropped" in result.flag_reasons[1]
    assert "non_finite" in result.flag_codes and result.n_samples == 6000 and result.valid
    assert json.loads(result.fit_options_json)["max_trial_samples"] == 6000


def test_missing_events_and_disagreeing_rates() -> None:
    rates = signal()
    assert fit_trial(batches_of(rates), None, event(1, count=N)).flag_codes[0] == "no_start"
    assert fit_trial(batches_of(rates), event(0), None).flag_codes[0] == "no_stop"
    ghost = fit_trial(batches_of(rates, "ghost")[:3], None, None)
    assert ghost.flag_codes[0] == "unknown_trial" and ghost.trial_id == "ghost" and not ghost.valid
    assert fit_trial(batches_of(rates), event(0), event(2, count=N)).flag_codes[0] == "aborted"
    odd = batches_of(rates)
    odd[4] = dataclasses.replace(odd[4], sample_rate_hz=999.0)
    mismatch = fit_trial(odd, event(0), event(1, count=N))
    assert mismatch.flag_codes[0] == "rate_mismatch" and "999, 1000 Hz" in mismatch.flag_reasons[0]
    empty = fit_trial([], event(0), event(1, count=0))
    assert not empty.valid and empty.n_samples == 0 and "empty" in empty.flag_codes


def test_options_round_trip_through_json() -> None:
    options = TrialFitOptions(
        FitOptions(WindowPolicy.span(0.5, 7.25, whole_cycles=False), 3.0, 0.8, 0.1, 0.25), 1234, 56
    )
    assert TrialFitOptions.from_json(options.to_json()) == options
    assert TrialFitOptions.from_json(TrialFitOptions().to_json()) == TrialFitOptions()


def state(**kw: Any) -> tuple[FitterState, RecordingLog, ManualClock]:
    log, clock = RecordingLog(), ManualClock()
    options = {"grace_s": 1.0, "history_grace_s": 0.0, **kw}  # steady state unless a test says otherwise
    return FitterState(TrialFitOptions(), log, clock=clock, **options), log, clock


def feed(s: FitterState, batches: Sequence[SampleBatch]) -> list[TrialFit]:
    out: list[TrialFit] = []
    for b in batches:
        out += s.on_batch(b, T0 + round(b.first_index * 1e6))
    return out


def test_state_fits_on_stop_whatever_the_order_of_the_two_topics() -> None:
    rates = signal()
    s, log, clock = state()
    batches = batches_of(rates)
    assert feed(s, batches[:10]) == []  # before the START: kept
    assert s.on_event(event(0)) == []
    assert feed(s, batches[10:-3]) == []
    assert s.on_event(event(1, count=N)) == []  # STOP before the last batches: waits
    done = feed(s, batches[-3:])
    assert len(done) == 1 and same(done[0].period, fit_trial(batches, event(0), event(1, count=N)).period)
    assert done[0].flag_codes == () and not [line for line in log.lines if line.startswith("W")]
    assert feed(s, batches[:1]) == []  # a late duplicate of a finished trial: ignored


def test_state_gives_up_waiting_after_grace_and_reports_unknown_trials() -> None:
    rates = signal()
    s, log, clock = state()
    s.on_event(event(0))
    feed(s, batches_of(rates)[:-1])
    assert s.on_event(event(1, count=N)) == []
    feed(s, batches_of(rates, "ghost")[:2])
    clock.now = 0.9
    assert s.poll() == []
    assert s.poll(live=False) == []
    clock.now = 1.0
    results = {r.trial_id: r for r in s.poll()}
    assert results["t"].flag_codes[0] == "gap" and results["ghost"].flag_codes[0] == "unknown_trial"
    assert any(line.startswith("W trial ghost (?): no period") and "unknown_trial" in line for line in log.lines)


def test_state_waits_for_the_history_after_a_restart() -> None:
    """Right after matching, a STOP whose batches have not arrived yet is not fitted yet.

    It is not fitted from what is there (Fast DDS delivers the history late), nor are open
    trials evicted; once the history window is over the usual grace applies.
    """
    rates = signal()
    s, log, clock = state(history_grace_s=5.0, max_open_trials=2)
    for i in range(4):  # events of 4 trials replayed before any of their batches
        s.on_event(event(0, trial_id=f"h{i}"))
        s.on_event(event(1, count=N, trial_id=f"h{i}"))
    clock.now = 4.9
    assert s.poll() == []
    out = []
    for i in range(4):  # then the batches arrive: every trial complete, none evicted
        out += feed(s, batches_of(rates, f"h{i}"))
    assert sorted(r.trial_id for r in out) == ["h0", "h1", "h2", "h3"]
    assert all(r.n_samples == N and not r.flag_codes for r in out)
    s.on_event(event(0, trial_id="late"))
    s.on_event(event(1, count=N, trial_id="late"))
    clock.now = 6.0
    (late,) = s.poll()
    assert late.trial_id == "late" and late.flag_codes[0] == "gap"


def test_a_rogue_process_never_evicts_cuts_or_duplicates_the_drivers_trials() -> None:
    """Junk from another participant (a rogue publisher on the domain) stays in its own trials."""
    rates = signal()
    s, log, clock = state(max_open_trials=4)
    driver, rogue = "driver-participant", "rogue-participant"
    batches = batches_of(rates)
    expected = fit_trial(batches, event(0), event(1, count=N))
    s.on_event(event(0), driver)
    s.on_event(event(0, trial_id="t2"), driver)
    out: list[TrialFit] = []
    for b in batches[:50]:
        out += s.on_batch(b, T0 + round(b.first_index * 1e6), driver)
    # the rogue: 5,000 unknown trials, a NaN batch where the driver's next one goes, a STOP cutting the trial short
    for i in range(5000):
        out += s.on_event(event(0, trial_id=f"junk{i}"), rogue)
    nan = SampleBatch("t", batches[50].first_index, RATE, np.full(50, np.nan))
    out += s.on_batch(nan, T0, rogue)
    out += s.on_event(event(1, count=2500), rogue)
    assert all(r.trial_id.startswith("junk") or r.trial_id == "t" for r in out)
    assert {("driver-participant", "t"), ("driver-participant", "t2")} <= set(s.open)  # none evicted
    for b in batches[50:]:
        out += s.on_batch(b, T0 + round(b.first_index * 1e6), driver)
    out += s.on_event(event(1, count=N), driver)
    real = [r for r in out if r.trial_id == "t" and r.n_samples == N]
    assert len(real) == 1 and same(real[0].period, expected.period) and real[0].flag_codes == ()
    assert len([k for k in s.open if k[0] == rogue]) <= 5  # the rogue bounded by its own limit (+ its "t")
    clock.now = 10.0
    # the rogue's batch of "t" came after the driver's START: dropped as it came; its STOP of
    # "t" ends without a START of its own: dropped, never published under the driver's id
    junk = [r for r in out + s.poll() if r.trial_id == "t" and r is not real[0]]
    assert junk == [] and s.foreign_batches == 1
    assert sum("another process than the one that started it" in m for m in log.lines) == 2
    assert ("driver-participant", "t2") not in s.done  # still the driver's, open until its STOP


def test_another_process_batches_of_a_trial_before_its_start_are_never_published() -> None:
    """The two topics are not ordered: a rogue's batches of the driver's next trial id may come first."""
    rates = signal()
    s, log, clock = state()
    batches = batches_of(rates)
    out = s.on_batch(SampleBatch("t", 0, 250.0, np.ones(50)), T0, "rogue")  # before any START of "t"
    out += s.on_event(event(0), "driver")
    for b in batches:
        out += s.on_batch(b, T0 + round(b.first_index * 1e6), "driver")
    out += s.on_event(event(1, count=N), "driver")
    out += s.on_batch(SampleBatch("t", 50, 250.0, np.ones(50)), T0, "rogue")  # after: dropped at once
    assert [(r.trial_id, r.n_samples, r.flag_codes) for r in out] == [("t", N, ())]
    clock.now = 100.0
    assert s.poll() == [] and ("rogue", "t") not in s.open and s.foreign_batches == 1
    assert any("another process" in line and "dropped, not published" in line for line in log.lines)


def test_a_stop_waits_while_its_sources_batches_still_arrive() -> None:
    """A fitter behind a burst: the STOPs came first, the batches are queued behind other trials'."""
    rates = signal()
    s, log, clock = state(grace_s=1.0, history_grace_s=5.0)
    clock.now = 10.0  # past the history window
    for tid in ("a", "b"):
        s.on_event(event(0, trial_id=tid), "drv")
        s.on_event(event(1, count=N, trial_id=tid), "drv")
    out: list[TrialFit] = []
    for b in batches_of(rates, "a"):  # a's batches take 3 s to work through: b waits meanwhile
        clock.now += 3.0 / len(batches_of(rates))
        out += s.on_batch(b, None, "drv") + s.poll()
    assert [r.trial_id for r in out] == ["a"]
    clock.now += 0.5
    assert s.poll() == []  # b's batches may still be queued: grace from the source's last batch
    out = []
    for b in batches_of(rates, "b"):
        out += s.on_batch(b, None, "drv")
    assert [(r.trial_id, r.n_samples, r.flag_codes) for r in out] == [("b", N, ())]
    # batches that never come: given up grace_s after the source's last one ...
    s.on_event(event(0, trial_id="c"), "drv")
    s.on_event(event(1, count=N, trial_id="c"), "drv")
    clock.now += 0.9
    assert s.poll() == []
    clock.now += 0.2
    assert [r.flag_codes[0] for r in s.poll()] == ["gap"]
    # ... and at most history_grace_s after the STOP while another trial streams on
    s.on_event(event(0, trial_id="d"), "drv")
    s.on_event(event(1, count=N, trial_id="d"), "drv")
    given_up: list[TrialFit] = []
    stopped_at = clock.now
    for b in batches_of(rates, "e"):
        clock.now += 0.05
        s.on_batch(b, None, "drv")
        given_up += s.poll()
        if given_up:
            break
    assert [r.trial_id for r in given_up] == ["d"] and 5.0 <= clock.now - stopped_at <= 6.1


def test_state_bounds_the_open_trials() -> None:
    s, log, _ = state(max_open_trials=2)
    out = []
    for i in range(3):
        out += s.on_event(event(0, trial_id=f"t{i}"))
        out += feed(s, batches_of(signal(200), f"t{i}"))
    assert [r.trial_id for r in out] == ["t0"] and out[0].flag_codes[0] == "no_stop"
    assert "more than 2 trials without STOP" in log.lines[0]


def test_state_does_not_republish_trials_older_than_the_gyro_history() -> None:
    rates = signal()
    s, log, clock = state()
    # history after a restart: trial "old" lost its batches, "new" is complete
    s.on_event(event(0, "old", ns=T0 - 10**10))
    s.on_event(event(1, "old", count=N, ns=T0 - 2 * 10**9))
    s.on_event(event(0, "new", ns=T0))
    feed(s, batches_of(rates, "new"))
    out = s.on_event(event(1, "new", count=N, ns=T0 + 8 * 10**9))
    clock.now = 5.0
    out += s.poll()
    assert [r.trial_id for r in out] == ["new"] and s.suppressed == 1
    assert any("old: began before the oldest gyro batch received" in line for line in log.lines)


# ---------------------------------------------------------------------- real processes


def expected_fields(result: TrialFit) -> dict[str, Any]:
    return {
        "trial_id": result.trial_id,
        "measurement_key": result.measurement_key,
        "n_samples": result.n_samples,
        "n_expected": result.n_expected,
        "window_start": result.window[0],
        "window_stop": result.window[1],
        "valid": result.valid,
        "flags": result.flag_codes,
        "flag_reasons": result.flag_reasons,
        "fit_options_json": result.fit_options_json,
    }


def assert_identical(estimate: Any, result: TrialFit) -> None:
    """A PeriodEstimate equals a fit_trial result: every float bit for bit."""
    for name in ("period", "period_sigma", "zeta", "omega", "r2", "residual_rms"):
        assert same(getattr(estimate, name), getattr(result.fit, name)), (result.trial_id, name)
    got = {k: getattr(estimate, k) for k in expected_fields(result)}
    got["flags"], got["flag_reasons"] = tuple(got["flags"]), tuple(got["flag_reasons"])
    assert got == expected_fields(result)
    assert estimate.header.stamp.sec * 1_000_000_000 + estimate.header.stamp.nanosec == result.stamp_ns


def test_every_trial_of_a_session_through_driver_and_fitter(
    probe: Probe, ros_env: dict[str, str], tmp_path: Path
) -> None:
    session, path = small_session(tmp_path)
    periods = probe.subscribe(PERIODS, msgs.PeriodEstimate)
    details = probe.subscribe(FIT_DETAILS, msgs.FitDetails)
    fitter_cmd = node_command("bike_rig.ros.nodes.fitter", params_file=str(config_file("fitter.yaml")))
    driver_cmd = node_command(
        "bike_rig.ros.nodes.driver",
        "source:=sim",
        f"session:={path}",
        "time_scale:=50.0",
        "pause_between_trials_s:=0.1",
        "start_time_s:=1700000000.0",
        "wait_for_subscribers:=1",
        params_file=str(config_file("driver.yaml")),
    )
    with (
        RosProcess("fitter", fitter_cmd, ros_env, tmp_path) as fitter,
        RosProcess("driver", driver_cmd, ros_env, tmp_path) as driver,
    ):
        probe.spin_until(
            lambda: len(periods) == len(details) == len(session.trials),
            STEP_TIMEOUT_S,
            "every trial's period and fit details",
            lambda: fitter.describe() + driver.describe(),
        )
        assert fitter.proc.poll() is None and driver.proc.poll() is None
    assert (fitter.proc.returncode, driver.proc.returncode) == (0, 0)

    options = TrialFitOptions.from_json(periods[0].fit_options_json)
    assert options == TrialFitOptions()  # config/fitter.yaml holds the defaults
    start_ns = T0
    for estimate, detail, truth in zip(periods, details, session.trials, strict=True):
        n = truth.rate.size
        stop_ns = start_ns + round(n * 1e6)
        start = event(0, truth.name, key=truth.key, ns=start_ns)
        stop = event(1, truth.name, count=n, key=truth.key, ns=stop_ns)
        expected = fit_trial(batches_of(truth.rate, truth.name), start, stop, options)
        assert_identical(estimate, expected)
        assert estimate.n_samples == estimate.n_expected == n
        got, want = messages.fit_details_from_msg(detail), FitDetails.of(expected)
        for f in dataclasses.fields(FitDetails):  # the ends period and the small-swing systematic too
            a, b = getattr(got, f.name), getattr(want, f.name)
            assert a == b or (isinstance(a, float) and same(a, b)), (truth.name, f.name, a, b)
        start_ns = stop_ns + 100_000_000


def fit_messages(batches: Sequence[Any], start: Any, stop: Any, options: TrialFitOptions | None = None) -> TrialFit:
    """``fit_trial`` of rclpy messages, converted as the fitter node converts them."""
    records = [messages.sample_batch_from_msg(b) for b in batches]
    return fit_trial(records, messages.trial_event_from_msg(start), messages.trial_event_from_msg(stop), options)


def synthetic_trial(trial_id: str, seed: int, n: int = N) -> tuple[Any, list[Any], Any]:
    """START, GyroBatch messages and STOP of a clean trial, as rclpy messages."""
    rates = signal(n, seed=seed)
    start = msgs.TrialEvent(
        kind=0,
        trial_id=trial_id,
        part="frame",
        pendulum="compound",
        measurement_key="TcB1",
        sample_rate_hz=RATE,
        sample_count=0,
    )
    batches = []
    for a in range(0, n, 50):
        b = msgs.GyroBatch(trial_id=trial_id, first_index=a, sample_rate_hz=RATE)
        b.rates = rates[a : a + 50].tolist()
        batches.append(b)
    stop = msgs.TrialEvent(
        kind=1,
        trial_id=trial_id,
        part="frame",
        pendulum="compound",
        measurement_key="TcB1",
        sample_rate_hz=RATE,
        sample_count=n,
    )
    return start, batches, stop


@pytest.fixture
def talker(probe: Probe) -> tuple[Probe, Any, Any, list[Any]]:
    """The probe as a driver stand-in: publishers of events and batches, the periods received."""
    events = probe.publisher(TRIAL_EVENTS, msgs.TrialEvent)
    gyro = probe.publisher(GYRO, msgs.GyroBatch)
    periods = probe.subscribe(PERIODS, msgs.PeriodEstimate)
    return probe, events, gyro, periods


#: The live fitter's waits in the tests whose trials lose batches on purpose, s. A fit with a gap is
#: compared exactly, so the grace must outlast any stall of the fitter between taking the STOP and
#: taking the batches still queued behind it (a busy machine's stalls last a second or two, the
#: default grace_s is 1 s). It costs that long once per trial given up on; complete trials are
#: fitted as soon as they are covered, without waiting.
GRACE = ("grace_s:=3.0", "history_grace_s:=3.0")


def wait_matched(probe: Probe, fitter: RosProcess, *publishers: Any) -> None:
    probe.spin_until(
        lambda: all(p.get_subscription_count() > 0 for p in publishers),
        STEP_TIMEOUT_S,
        "the fitter's subscriptions",
        fitter.describe,
    )


def test_bad_input_is_logged_flagged_and_the_fitter_keeps_serving(
    talker: tuple[Probe, Any, Any, list[Any]], ros_env: dict[str, str], tmp_path: Path
) -> None:
    probe, events, gyro, periods = talker
    # (history_grace_s: the fitter starts before any history exists, so nothing late is expected)
    cmd = node_command("bike_rig.ros.nodes.fitter", *GRACE, "max_batch_samples:=1000")
    options = TrialFitOptions(max_batch_samples=1000)

    def by_id(trial_id: str) -> Any:
        probe.spin_until(
            lambda: any(p.trial_id == trial_id for p in periods),
            STEP_TIMEOUT_S,
            f"the period of {trial_id}",
            fitter.describe,
        )
        return next(p for p in periods if p.trial_id == trial_id)

    with RosProcess("fitter", cmd, ros_env, tmp_path) as fitter:
        wait_matched(probe, fitter, events, gyro)
        # a batch with NaN
        start, batches, stop = synthetic_trial("nan_trial", 1)
        rates = list(batches[7].rates)
        rates[11] = math.nan
        batches[7].rates = rates
        for m in (start, *batches, stop):
            (events if isinstance(m, msgs.TrialEvent) else gyro).publish(m)
        nan = by_id("nan_trial")
        assert nan.valid and "non_finite" in nan.flags
        assert_identical(nan, fit_messages(batches, start, stop, options))

        # batches of a trial nobody announced
        _, ghost, _ = synthetic_trial("ghost", 2, n=200)
        for m in ghost:
            gyro.publish(m)
        assert list(by_id("ghost").flags)[:1] == ["unknown_trial"]

        # a STOP without START
        _, _, lonely = synthetic_trial("lonely", 3)
        events.publish(lonely)
        assert list(by_id("lonely").flags)[:2] == ["no_start", "gap"]

        # an oversized batch (and a duplicate and a lost batch)
        start, batches, stop = synthetic_trial("big", 4)
        huge = msgs.GyroBatch(trial_id="big", first_index=2000, sample_rate_hz=RATE)
        huge.rates = [0.0] * 5000
        sent = [*batches[:30], huge, batches[12], *batches[31:]]  # batch 30 lost, 12 twice
        for m in (start, *sent, stop):
            (events if isinstance(m, msgs.TrialEvent) else gyro).publish(m)
        big = by_id("big")
        assert list(big.flags)[:2] == ["oversized_batch", "gap"] and big.n_samples == N - 50
        assert "50 samples missing in 1 gap(s): [1500, 1550)" in big.flag_reasons[1]
        assert_identical(big, fit_messages(sent, start, stop, options))

        # and a good trial afterwards
        start, batches, stop = synthetic_trial("good", 5)
        for m in (start, *batches, stop):
            (events if isinstance(m, msgs.TrialEvent) else gyro).publish(m)
        good = by_id("good")
        assert good.valid and list(good.flags) == [] and good.n_samples == N
        assert_identical(good, fit_messages(batches, start, stop, options))
        assert fitter.proc.poll() is None
    assert fitter.proc.returncode == 0, fitter.describe()
    log = fitter.stderr_path.read_text()
    for line in (
        "trial nan_trial: 1 NaN/infinite samples in the batch at index 350",
        "trial ghost (?): no period, 200/0 samples; flags: unknown_trial",
        "trial lonely: STOP without START",
        "trial big: batch of 5000 samples at index 2000 rejected (max_batch_samples 1000)",
        "trial big: duplicate batch at index 600 ignored",
    ):
        assert line in log, log


def test_a_restarted_fitter_refits_the_trial_in_progress(
    talker: tuple[Probe, Any, Any, list[Any]], ros_env: dict[str, str], tmp_path: Path
) -> None:
    probe, events, gyro, periods = talker
    cmd = node_command("bike_rig.ros.nodes.fitter", "grace_s:=3.0")  # (both trials complete: never waited out)
    done_a, batches_a, stop_a = synthetic_trial("a", 6)
    start_b, batches_b, stop_b = synthetic_trial("b", 7)
    with RosProcess("fitter1", cmd, ros_env, tmp_path) as fitter:
        wait_matched(probe, fitter, events, gyro)
        for m in (done_a, *batches_a, stop_a, start_b, *batches_b[:70]):
            (events if isinstance(m, msgs.TrialEvent) else gyro).publish(m)
        probe.spin_until(lambda: len(periods) == 1, STEP_TIMEOUT_S, "the period of a", fitter.describe)
    assert fitter.proc.returncode == 0
    # the first fitter is gone from the graph before the second one is waited for
    probe.spin_until(
        lambda: events.get_subscription_count() == 0 and gyro.get_subscription_count() == 0,
        STEP_TIMEOUT_S,
        "the first fitter to leave",
    )
    for m in batches_b[70:120]:  # while no fitter runs
        gyro.publish(m)
    with RosProcess("fitter2", cmd, ros_env, tmp_path) as fitter:
        wait_matched(probe, fitter, events, gyro)
        for m in (*batches_b[120:], stop_b):
            (events if isinstance(m, msgs.TrialEvent) else gyro).publish(m)
        probe.spin_until(
            lambda: any(p.trial_id == "b" for p in periods), STEP_TIMEOUT_S, "the period of b", fitter.describe
        )
    b = next(p for p in periods if p.trial_id == "b")
    assert_identical(b, fit_messages(batches_b, start_b, stop_b))
    assert b.n_samples == N and list(b.flags) == []
    expected_a = fit_messages(batches_a, done_a, stop_a)
    of_a = [p for p in periods if p.trial_id == "a"]  # the first fitter's, and the second's re-fit
    assert len(of_a) >= 1
    for estimate in of_a:
        assert_identical(estimate, expected_a)


@pytest.mark.parametrize(
    ("parameters", "message"),
    [
        (["window:=foo"], "fitter: error: parameter 'window' = 'foo': expected one of lead_in, span, envelope"),
        (["grace_s:=1"], "fitter: error: parameter 'grace_s': expected a double (e.g. 1.0)"),
        (["max_batch_samples:=0"], "fitter: error: parameter 'max_batch_samples': must be within [1, 2147483648]"),
    ],
)
def test_bad_parameters_end_in_one_line(parameters: list[str], message: str, ros_env: dict[str, str]) -> None:
    cmd = node_command("bike_rig.ros.nodes.fitter", *parameters, params_file=str(config_file("fitter.yaml")))
    done = subprocess.run(["timeout", "-k", "5", "60", *cmd], env=ros_env, capture_output=True, text=True, timeout=90)
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines() == [message]


def test_lost_batches_are_fetched_again_from_the_drivers_resend_service(
    talker: tuple[Probe, Any, Any, list[Any]], ros_env: dict[str, str], tmp_path: Path
) -> None:
    """The probe stands in for a driver that lost batches on the way but serves ResendSamples.

    A trial whose batches never reached the fitter is fitted whole from the driver's answer,
    identical to the fit of every batch; samples the driver itself never had are a ``gap``
    that says so.
    """
    probe, events, gyro, periods = talker
    srvs: Any = __import__("bike_rig_msgs.srv", fromlist=["ResendSamples"])
    sent = SentBatches()
    asked: list[tuple[str, int, int]] = []

    def on_resend(request: Any, response: Any) -> Any:
        asked.append((request.trial_id, request.first_index, request.count))
        got = sent.resend(request.trial_id, request.first_index, request.count)
        response.held, response.complete, response.message = got.held, got.complete, got.message
        response.batches = [messages.fill_gyro_batch(msgs.GyroBatch(), b) for b in got.batches]
        return response

    probe.node.create_service(srvs.ResendSamples, RESEND_SAMPLES, on_resend)
    cmd = node_command("bike_rig.ros.nodes.fitter", *GRACE)

    def by_id(trial_id: str) -> Any:
        probe.spin_until(
            lambda: any(p.trial_id == trial_id for p in periods),
            STEP_TIMEOUT_S,
            f"the period of {trial_id}",
            fitter.describe,
        )
        return next(p for p in periods if p.trial_id == trial_id)

    with RosProcess("fitter", cmd, ros_env, tmp_path) as fitter:
        wait_matched(probe, fitter, events, gyro)
        start, batches, stop = synthetic_trial("lossy", 6)
        for b in batches:
            sent.add(messages.sample_batch_from_msg(b))
        lost = {3, 4, 50, len(batches) - 1}  # in the middle and the last one
        for m in (start, *[b for i, b in enumerate(batches) if i not in lost], stop):
            (events if isinstance(m, msgs.TrialEvent) else gyro).publish(m)
        whole = by_id("lossy")
        assert list(whole.flags) == [] and whole.n_samples == N
        assert_identical(whole, fit_messages(batches, start, stop))
        assert asked and asked[0][:2] == ("lossy", 150)

        start, batches, stop = synthetic_trial("holey", 7)
        for i, b in enumerate(batches):
            if i != 10:  # the driver itself never had batch 10
                sent.add(messages.sample_batch_from_msg(b))
        for m in (start, *[b for i, b in enumerate(batches) if i not in (10, 11)], stop):
            (events if isinstance(m, msgs.TrialEvent) else gyro).publish(m)
        holey = by_id("holey")
        assert list(holey.flags)[:1] == ["gap"] and holey.n_samples == N - 50
        assert "50 samples missing in 1 gap(s): [500, 550) (the driver never had them)" in holey.flag_reasons[0]
        expected = fit_messages([b for i, b in enumerate(batches) if i != 10], start, stop)
        assert (holey.period, holey.period_sigma) == (expected.period, expected.period_sigma)
    log = fitter.stderr_path.read_text()
    assert "trial lossy: 200 samples lost on the way; asked the driver again" in log, log
    assert "trial lossy: the lost samples came again from the driver" in log, log
