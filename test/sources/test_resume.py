"""Resume: where an interrupted session's bag stands, and the driver's source that streams it again first."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bike_rig.bag.errors import BagError
from bike_rig.bag.simulated import SimulatedMessage, simulated_messages
from bike_rig.bag.typestore import new_message, rig_typestore
from bike_rig.bag.writer import BagWriter, contract_qos
from bike_rig.config import topics
from bike_rig.core.sim import SimulatedSession, load_rig, load_true_parameters, simulate_session
from bike_rig.messages import fill_reading_entry
from bike_rig.offline.resume import NO_STATIC_READINGS, resume_point
from bike_rig.pipeline.readings import ReadingEntry
from bike_rig.sources.base import RigClock, SampleBlock, SourceEvent, TrialRequest, TrialStarted, TrialStopped
from bike_rig.sources.errors import SourceConfigError
from bike_rig.sources.resume import ResumedSource
from bike_rig.sources.sim import SimSource
from test.support.small_sessions import BICYCLE, START_NS, operator_source, small_rig

#: Trials recorded before the interruption (the last of them left open).
RECORDED = 4


def _session(tmp_path: Path) -> SimulatedSession:
    name, truth = load_true_parameters(BICYCLE)
    return simulate_session(truth, load_rig(small_rig(tmp_path)), 3, name)


def _interrupted(session: SimulatedSession, static_source: str = "") -> list[SimulatedMessage]:
    """The first RECORDED trials as a live recorder gets them, and two reading entries.

    Each trial's first batch is logged before its START (another topic); the last trial has no STOP.
    """
    cut = replace(session, trials=session.trials[:RECORDED])
    out = list(simulated_messages(cut))
    last = session.trials[RECORDED - 1].name
    out = [
        m
        for m in out
        if not (m.topic == topics.TRIAL_EVENTS.name and m.message.kind != 0 and m.message.trial_id == last)
    ]
    for k, m in enumerate(out):
        if m.topic == topics.TRIAL_EVENTS.name and m.message.kind == 0:  # START: its first batch came first
            batch = next(b for b in out[k:] if b.topic == topics.GYRO.name)
            out[out.index(batch)] = replace(batch, log_time=m.log_time - 1)
    if static_source:
        out[0].message.source = static_source
    entries = [ReadingEntry("mR", 3.1, 0.02, stamp_ns=START_NS + k, note=n) for k, n in enumerate(("", "correction"))]
    t = out[0].log_time
    out += [
        SimulatedMessage(topics.READINGS.name, t + k + 1, fill_reading_entry(new_message(topics.READINGS.type), e))
        for k, e in enumerate(entries)
    ]
    return sorted(out, key=lambda m: m.log_time)


def _write(path: Path, messages: list[SimulatedMessage], close: bool = True) -> Path:
    store = rig_typestore()
    types = {t.name: t.type for t in topics.TOPICS}
    w = BagWriter(path, flush_period_s=3600.0)
    w.open()
    for t in topics.TOPICS:
        w.add_topic(t.name, t.type, offered_qos=[contract_qos(t.qos)])
    for m in messages:
        w.write(m.topic, m.log_time, bytes(store.serialize_cdr(m.message, types[m.topic])))
    if close:
        w.close()
    else:
        w.flush()
        w.abort()  # as a killed recorder leaves it
    return path


def _events(source: ResumedSource, polls: int = 1000) -> list[SourceEvent]:
    out: list[SourceEvent] = []
    for _ in range(polls):
        if not source.replaying:
            break
        out += source.poll()
    return out


def test_resume_point_reads_trials_entries_and_what_is_left_open(tmp_path: Path) -> None:
    session = _session(tmp_path)
    bag = _write(tmp_path / "bag", _interrupted(session))
    point = resume_point(tmp_path, tmp_path / "unused")  # a session folder: its bag
    assert point.bag == tmp_path / "bag" and not point.recovered and not (tmp_path / "unused").exists()
    assert point.trial_ids == tuple(t.name for t in session.trials[:RECORDED])
    assert point.open_trials == (session.trials[RECORDED - 1].name,)
    assert [(e.key, e.value, e.note) for e in point.entries] == [("mR", 3.1, ""), ("mR", 3.1, "correction")]
    assert point.bicycle == session.bicycle
    assert point.last_stamp_ns > START_NS
    assert "4 trials (1 left open: recorded as aborted) and 2 readings" in point.describe()
    assert resume_point(bag, tmp_path / "unused").trial_ids == point.trial_ids  # the bag itself


def test_a_bag_that_did_not_end_cleanly_is_resumed_from_its_recovered_copy(tmp_path: Path) -> None:
    session = _session(tmp_path)
    _write(tmp_path / "bag", _interrupted(session), close=False)
    point = resume_point(tmp_path / "bag", tmp_path / "recovered")
    assert point.recovered and point.bag == tmp_path / "recovered"
    assert point.trial_ids == tuple(t.name for t in session.trials[:RECORDED])
    assert "recovered" in point.describe()
    with pytest.raises(BagError, match="no such session folder or bag"):
        resume_point(tmp_path / "nothing", tmp_path / "r2")


@pytest.mark.parametrize(
    ("source", "document", "suffix"),
    [
        (NO_STATIC_READINGS, False, ""),
        ("3 reading entries", False, ""),
        ("1 reading entry", False, ""),
        ("/lab/browser.txt", True, ".txt"),
        ("/lab/browser.yaml + 2 reading entries", True, ".yaml"),
        ("/lab/BrowserMeasured.txt + 1 reading entry", True, ".yaml"),  # the entries applied: a YAML document
    ],
)
def test_the_static_readings_a_session_started_from(tmp_path: Path, source: str, document: bool, suffix: str) -> None:
    session = _session(tmp_path)
    messages = _interrupted(session, static_source=source)
    messages[0].message.document = "the document"
    point = resume_point(_write(tmp_path / "bag", messages), tmp_path / "r")
    assert (point.readings_document, point.readings_suffix) == (("the document", suffix) if document else ("", ""))


def _sim_and_bag(tmp_path: Path) -> tuple[SimulatedSession, Path]:
    session = _session(tmp_path)
    return session, _write(tmp_path / "bag", _interrupted(session))


def test_the_recorded_trials_come_first_whole_and_in_order_then_the_live_ones(tmp_path: Path) -> None:
    session, bag = _sim_and_bag(tmp_path)
    live = operator_source(tmp_path, RigClock(START_NS, math.inf))
    source = ResumedSource(str(bag), live, time_scale=1e9)
    assert source.name == "sim" and source.supports_requests and source.recorded_trials == RECORDED
    events = _events(source)
    starts = [e for e in events if isinstance(e, TrialStarted)]
    stops = [e for e in events if isinstance(e, TrialStopped)]
    assert [e.info.trial_id for e in starts] == [t.name for t in session.trials[:RECORDED]]
    for trial, stop in zip(session.trials[:RECORDED], stops, strict=True):
        blocks = [e for e in events if isinstance(e, SampleBlock) and e.trial_id == trial.name]
        assert [b.first_index for b in blocks] == sorted(b.first_index for b in blocks)  # grouped, in order
        assert np.array_equal(np.concatenate([b.rates for b in blocks]), trial.rate)
        assert stop.trial_id == trial.name and stop.sample_count == trial.rate.size
        assert stop.aborted == (trial is session.trials[RECORDED - 1])  # the open one: ABORT after its samples
    # the session goes on where it stopped: the next measurement gets the uninterrupted session's trial
    nxt = session.trials[RECORDED]
    planned = next(m for m in session.plan if m.key == nxt.key)
    info = source.start_trial(TrialRequest(planned.part, planned.pendulum, planned.orientation or 0))
    assert info.trial_id == nxt.name and info.trial_id not in {e.info.trial_id for e in starts}
    blocks = [e for e in source.poll() if isinstance(e, SampleBlock)]
    assert np.array_equal(np.concatenate([b.rates for b in blocks]), nxt.rate)
    # a redo of a recorded repeat gets a new id
    first = session.trials[0]
    planned = next(m for m in session.plan if m.key == first.key)
    redo = source.start_trial(TrialRequest(planned.part, planned.pendulum, planned.orientation or 0, repeat=1))
    assert redo.trial_id.startswith(first.name) and redo.trial_id != first.name


def test_the_recorded_trials_are_paced_by_the_time_scale(tmp_path: Path) -> None:
    session, bag = _sim_and_bag(tmp_path)
    now = [0.0]
    scale = 100.0
    source = ResumedSource(str(bag), operator_source(tmp_path, RigClock(START_NS, math.inf)), scale, lambda: now[0])
    first = source.poll()
    assert isinstance(first[0], TrialStarted) and not any(isinstance(e, TrialStopped) for e in first)
    trial = session.trials[0]
    seconds = trial.rate.size / trial.sample_rate / scale  # its rig time at the time scale
    now[0] = seconds * 0.999
    assert not any(isinstance(e, TrialStopped) for e in source.poll())
    now[0] = seconds * 1.001
    assert any(isinstance(e, TrialStopped) for e in source.poll())
    total = sum(t.rate.size / t.sample_rate for t in session.trials[:RECORDED]) / scale
    now[0] = total * 0.99
    source.poll()
    assert source.replaying
    now[0] = total * 1.01
    source.poll()
    assert not source.replaying


def test_resume_needs_a_source_that_records_on_request_and_a_readable_bag(tmp_path: Path) -> None:
    _, bag = _sim_and_bag(tmp_path)
    plan_walker: Any = SimSource.__new__(SimSource)  # its class says it walks its own plan
    with pytest.raises(SourceConfigError, match="records trials on request"):
        ResumedSource(str(bag), plan_walker)
    with pytest.raises(SourceConfigError, match="no such"):
        ResumedSource(str(tmp_path / "nothing"), operator_source(tmp_path, RigClock(START_NS, math.inf)))


def test_session_resume_mistakes_end_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from bike_rig.cli.main import main

    session = _session(tmp_path)
    _write(tmp_path / "old" / "bag", _interrupted(session))
    cases = [
        (["--resume", str(tmp_path / "nothing")], "no such session folder or bag"),
        (["--join", "--resume", str(tmp_path / "old")], "cannot be used with --join"),
        (["--resume", str(tmp_path)], "not a rosbag2 bag"),
        (["--resume", str(tmp_path / "old"), "--name", "Fisher"], f"the session is of bicycle {session.bicycle!r}"),
    ]
    for args, reason in cases:
        code = main(["session", "--plain", "--output", str(tmp_path / "new"), *args])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and reason in err[0], (args, err)
        assert not (tmp_path / "new").exists()  # nothing started, nothing written
