"""Lost batches are asked for again: the driver's memory of what it sent, and the fitter's waiting rule.

ROS-free: :class:`~bike_rig.pipeline.resend.SentBatches` (what the driver answers) and
:class:`~bike_rig.pipeline.fit_state.FitterState` with a resend service (when a STOP's missing
batches are known lost, what is asked for, and what an answer makes of the trial).
"""

from __future__ import annotations

import numpy as np

from bike_rig.config.topics import GYRO
from bike_rig.pipeline.acquire import SampleBatch, TrialEventKind, TrialEventRecord
from bike_rig.pipeline.fit import TrialFit, TrialFitOptions, fit_trial
from bike_rig.pipeline.fit_state import RESEND_GIVE_UP_S, RESEND_RETRY_S, FitterState, ResendRequest
from bike_rig.pipeline.resend import (
    DEFAULT_HISTORY_SAMPLES,
    MAX_SCALED_BATCH,
    SentBatches,
    batch_samples,
    history_depth,
)
from test.support.fakes import ManualClock, RecordingLog

RATE = 1000.0
N = 6000
DRV = "driver-participant"


def event(kind: int, trial_id: str, count: int = 0) -> TrialEventRecord:
    return TrialEventRecord(TrialEventKind(kind), trial_id, "TtB1", sample_rate_hz=RATE, sample_count=count)


def signal(seed: int = 1) -> np.ndarray:
    t = np.arange(N) / RATE
    noise = 1e-4 * np.random.default_rng(seed).standard_normal(N)
    return 0.05 * np.exp(-0.01 * t) * np.sin(2 * np.pi * t / 0.9 + 0.3) + noise


def batches_of(trial_id: str, rates: np.ndarray, size: int = 500) -> list[SampleBatch]:
    return [SampleBatch(trial_id, a, RATE, rates[a : a + size]) for a in range(0, rates.size, size)]


def resending_state() -> tuple[FitterState, RecordingLog, ManualClock]:
    log, clock = RecordingLog(), ManualClock(100.0)
    s = FitterState(TrialFitOptions(), log, grace_s=1.0, clock=clock, history_grace_s=0.0)
    s.can_resend = True
    return s, log, clock


def feed(s: FitterState, batches: list[SampleBatch]) -> list[TrialFit]:
    out: list[TrialFit] = []
    for b in batches:
        out += s.on_batch(b, None, DRV)
    return out


def answer(s: FitterState, sent: SentBatches, wants: list[ResendRequest]) -> list[TrialFit]:
    out: list[TrialFit] = []
    for w in wants:
        got = sent.resend(w.trial_id, w.first_index, w.count)
        out += s.on_resent(w.source, w.trial_id, got.held, got.complete, list(got.batches))
    return out


# ---------------------------------------------------------------------- the driver's side


def test_batches_grow_with_the_time_scale_so_the_message_rate_stays() -> None:
    assert batch_samples(50, 1.0) == 50
    assert batch_samples(50, 0.5) == 50
    assert batch_samples(50, 25.0) == 1250
    assert batch_samples(50, 2.5) == 150
    assert batch_samples(50, 1000.0) == MAX_SCALED_BATCH
    assert batch_samples(20_000, 1.0) == 20_000  # (never below what was asked for)
    # the topic's history holds the same samples whatever the batch size
    assert history_depth(DEFAULT_HISTORY_SAMPLES, 50) == GYRO.qos.depth == 50_000
    assert history_depth(DEFAULT_HISTORY_SAMPLES, 5000) == 500 and history_depth(10, 3) == 4


def test_sent_batches_answer_the_overlapping_range_and_forget_the_oldest_trial() -> None:
    sent = SentBatches(max_samples=2 * N)
    for tid in ("a", "b"):
        for b in batches_of(tid, signal()):
            sent.add(b)
    got = sent.resend("a", 1200, 600)  # overlaps the batches at 1000 and 1500
    assert got.held and got.complete and [b.first_index for b in got.batches] == [1000, 1500]
    whole = sent.resend("b", 0, 0)
    assert whole.complete and sum(len(b.rates) for b in whole.batches) == N
    cut = sent.resend("b", 0, 0, limit=1200)
    assert not cut.complete and [b.first_index for b in cut.batches] == [0, 500]
    sent.add(batches_of("c", signal())[0])  # over the budget: trial a is forgotten whole
    assert not sent.resend("a", 0, 0).held and sent.resend("b", 0, 0).held and sent.forgotten == 1
    assert not sent.resend("never", 0, 0).held


# ---------------------------------------------------------------------- the fitter's side


def test_a_fitter_far_behind_waits_however_long_and_asks_for_nothing() -> None:
    """STOPs overtake the batches by minutes on a loaded machine: nothing is given up or asked for."""
    s, log, clock = resending_state()
    rates = signal()
    for tid in ("a", "b"):
        s.on_event(event(0, tid), DRV)
        s.on_event(event(1, tid, N), DRV)
    out: list[TrialFit] = []
    for b in batches_of("a", rates, size=50):  # a's batches trickle in over two minutes
        clock.now += 1.0
        out += s.on_batch(b, None, DRV) + s.poll()
    assert [r.trial_id for r in out] == ["a"] and s.take_resend_requests() == []
    clock.now += 0.5
    assert s.poll() == [] and s.take_resend_requests() == []  # b's may be next in the queue
    out = feed(s, batches_of("b", rates))
    assert [(r.trial_id, r.n_samples, r.flag_codes) for r in out] == [("b", N, ())]


def test_lost_batches_are_asked_for_once_the_stream_has_passed_them() -> None:
    s, log, clock = resending_state()
    rates = signal()
    sent = SentBatches()
    a = batches_of("a", rates)
    for b in a + batches_of("b", rates):
        sent.add(b)
    s.on_event(event(0, "a"), DRV)
    feed(s, a[:3] + a[5:9])  # a[3:5] and a[9:] lost on the way
    s.on_event(event(1, "a", N), DRV)
    assert s.poll() == [] and s.take_resend_requests() == []  # they may still come
    s.on_event(event(0, "b"), DRV)
    feed(s, batches_of("b", rates)[:1])  # a batch of a trial started after a's STOP: a's are lost
    assert s.poll() == []
    wants = s.take_resend_requests()
    assert [(w.trial_id, w.first_index, w.count) for w in wants] == [("a", 1500, 4500)]  # (one span)
    (fit,) = answer(s, sent, wants)
    expected = fit_trial(a, event(0, "a"), event(1, "a", N))
    assert fit.n_samples == N and fit.flag_codes == () and fit.period == expected.period
    assert any("lost on the way; asked the driver again" in line for line in log.lines)


def test_samples_the_driver_never_had_are_a_gap_that_says_so() -> None:
    s, log, clock = resending_state()
    a = batches_of("a", signal())
    sent = SentBatches()
    for b in a[:4] + a[6:]:  # the source itself lost a[4:6]
        sent.add(b)
    s.on_event(event(0, "a"), DRV)
    feed(s, a[:2] + a[8:])
    s.on_event(event(1, "a", N), DRV)
    clock.now += 1.0  # the source's batches silent for grace_s: lost
    assert s.poll() == []
    (fit,) = answer(s, sent, s.take_resend_requests())
    assert fit.flag_codes[0] == "gap" and "1000 samples missing" in fit.flags[0].reason
    assert "the driver never had them" in fit.flags[0].reason


def test_a_trial_the_driver_no_longer_holds_is_a_gap_that_says_so() -> None:
    s, log, clock = resending_state()
    a = batches_of("a", signal())
    s.on_event(event(0, "a"), DRV)
    feed(s, a[:-1])
    s.on_event(event(1, "a", N), DRV)
    clock.now += 1.0
    s.poll()
    (fit,) = answer(s, SentBatches(), s.take_resend_requests())
    assert fit.flag_codes[0] == "gap" and "the driver no longer holds them" in fit.flags[0].reason


def test_a_partial_answer_is_followed_by_a_request_for_the_rest() -> None:
    s, log, clock = resending_state()
    a = batches_of("a", signal())
    sent = SentBatches()
    for b in a:
        sent.add(b)
    s.on_event(event(0, "a"), DRV)
    feed(s, a[:1])
    s.on_event(event(1, "a", N), DRV)
    clock.now += 1.0
    s.poll()
    (want,) = s.take_resend_requests()
    got = sent.resend(want.trial_id, want.first_index, want.count, limit=1000)
    assert not got.complete
    assert s.on_resent(DRV, "a", got.held, got.complete, list(got.batches)) == []
    s.poll()
    (rest,) = s.take_resend_requests()
    assert (rest.first_index, rest.count) == (1500, N - 1500)
    (fit,) = answer(s, sent, [rest])
    assert fit.n_samples == N and fit.flag_codes == ()


def test_an_unanswered_request_is_repeated_then_given_up() -> None:
    s, log, clock = resending_state()
    a = batches_of("a", signal())
    s.on_event(event(0, "a"), DRV)
    feed(s, a[:-2])
    s.on_event(event(1, "a", N), DRV)
    clock.now += 1.0
    s.poll()
    asked = len(s.take_resend_requests())
    clock.now += RESEND_RETRY_S / 2
    s.poll()
    assert asked == 1 and s.take_resend_requests() == []
    clock.now += RESEND_RETRY_S
    s.poll()
    assert len(s.take_resend_requests()) == 1
    clock.now += RESEND_GIVE_UP_S
    (fit,) = s.poll()
    assert fit.flag_codes[0] == "gap" and "did not answer" in fit.flags[0].reason


def test_an_answer_that_comes_after_the_original_batches_changes_nothing() -> None:
    """Asked for while the batches were only late: the late originals finish the trial, the answer is ignored."""
    s, log, clock = resending_state()
    a = batches_of("a", signal())
    sent = SentBatches()
    for b in a:
        sent.add(b)
    s.on_event(event(0, "a"), DRV)
    feed(s, a[:-2])
    s.on_event(event(1, "a", N), DRV)
    clock.now += 1.0
    assert s.poll() == []
    wants = s.take_resend_requests()
    (fit,) = feed(s, a[-2:])
    assert fit.n_samples == N and fit.flag_codes == ()
    assert answer(s, sent, wants) == [] and s.poll() == []


def test_batches_that_come_after_the_trial_was_published_with_a_gap_refit_it() -> None:
    """No resend service (a republished recording): given up after grace, fitted again once whole."""
    log, clock = RecordingLog(), ManualClock(100.0)
    s = FitterState(TrialFitOptions(), log, grace_s=1.0, clock=clock, history_grace_s=0.0)
    a = batches_of("a", signal())
    s.on_event(event(0, "a"), DRV)
    feed(s, a[:3] + a[5:])
    s.on_event(event(1, "a", N), DRV)
    clock.now += 1.0
    (first,) = s.poll()
    assert first.flag_codes[0] == "gap" and first.n_samples == N - 1000
    assert feed(s, a[3:4]) == []  # still one batch short
    (again,) = feed(s, a[4:5])
    expected = fit_trial(a, event(0, "a"), event(1, "a", N))
    assert again.n_samples == N and again.flag_codes == () and again.period == expected.period
    assert feed(s, a[4:5]) == []  # (a whole trial ignores late copies)
    assert any("its missing samples came late; fitted again" in line for line in log.lines)


def test_a_stop_without_start_is_fitted_as_it_is_and_the_driver_is_not_asked() -> None:
    """Another process's STOP of an id (no START from it): the driver knows nothing of that trial."""
    s, log, clock = resending_state()
    rogue = "rogue-participant"
    s.on_batch(SampleBatch("t", 0, RATE, np.full(50, np.nan)), None, rogue)
    s.on_event(event(1, "t", 100), rogue)
    assert s.poll() == []
    clock.now += 1.5  # silent for longer than grace_s
    (fit,) = s.poll()
    assert fit.trial_id == "t" and "no_start" in fit.flag_codes and s.take_resend_requests() == []
