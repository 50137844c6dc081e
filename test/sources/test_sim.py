"""The sim source: a written session and an in-memory one.

Both are streamed in plan order, paced in rig time; bad configurations end in one error that
names the parameter, the value and the reason.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from bike_rig.core.sim.plan import measurement_plan
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
    drain,
    open_source,
)
from bike_rig.sources.sim import SimSource, session_file_trials
from test.support.fakes import ManualClock
from test.support.small_sessions import BICYCLE, TRIAL_S, small_rig, small_session

START_NS = 1_700_000_000_123_456_789


def per_trial(events: list[SourceEvent]) -> list[tuple[TrialStarted, np.ndarray, TrialStopped]]:
    """The events grouped by trial, checking their order: START, contiguous blocks, STOP."""
    out = []
    current: TrialStarted | None = None
    blocks: list[np.ndarray] = []
    for ev in events:
        if isinstance(ev, TrialStarted):
            assert current is None, "a trial started inside another"
            current, blocks = ev, []
        elif isinstance(ev, SampleBlock):
            assert current is not None and ev.trial_id == current.info.trial_id
            assert ev.first_index == sum(b.size for b in blocks)
            blocks.append(ev.rates)
        else:
            assert current is not None and ev.trial_id == current.info.trial_id
            out.append((current, np.concatenate(blocks), ev))
            current = None
    assert current is None
    return out


def test_written_session_streams_every_trial_in_plan_order(tmp_path: Path) -> None:
    session, path = small_session(tmp_path)
    pause = 0.25
    source = SimSource(session_file_trials(path), RigClock(START_NS, math.inf), pause_between_trials_s=pause)
    trials = per_trial(list(drain(source)))

    plan = measurement_plan(3, 3)
    assert [t[0].info.measurement_key for t in trials] == [m.key for m in plan]
    assert [t[0].info.trial_id for t in trials] == [t.name for t in session.trials]
    expected_start = START_NS
    for (started, rates, stopped), truth, m in zip(trials, session.trials, plan):
        info = started.info
        assert (info.part, info.pendulum, info.orientation, info.repeat) == (m.part, m.pendulum, m.orientation or 0, 1)
        assert info.sample_rate_hz == 1000.0
        assert np.array_equal(rates, truth.rate)  # exactly the file's samples
        assert started.stamp_ns == expected_start
        assert stopped.sample_count == truth.rate.size == round(TRIAL_S * 1000)
        assert stopped.stamp_ns == sample_stamp_ns(started.stamp_ns, stopped.sample_count, 1000.0)
        assert not stopped.aborted
        expected_start = stopped.stamp_ns + round(pause * 1e9)
    assert source.finished


def test_written_session_streams_raw_volts(tmp_path: Path) -> None:
    session, path = small_session(tmp_path)
    source = SimSource(session_file_trials(path), RigClock(START_NS, math.inf))
    blocks = [e for e in drain(source) if isinstance(e, SampleBlock)]
    first = session.trials[0]
    volts = np.concatenate([b.raw_volts for b in blocks if b.trial_id == first.name and b.raw_volts is not None])
    assert np.array_equal(volts, first.volts)


def test_in_memory_session_equals_the_simulated_one_and_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    rig = small_rig(tmp_path)
    session, _ = small_session(tmp_path / "reference")
    workdir = tmp_path / "cwd"
    workdir.mkdir()
    monkeypatch.chdir(workdir)
    source = open_source("sim", bicycle=str(BICYCLE), rig=str(rig), seed=3, time_scale=1000.0)
    assert isinstance(source, SimSource)
    source.clock = RigClock(START_NS, math.inf)
    trials = per_trial(list(drain(source)))
    assert [t[0].info.trial_id for t in trials] == [t.name for t in session.trials]
    for (_, rates, stopped), truth in zip(trials, session.trials):
        assert np.array_equal(rates, truth.rate)
        assert stopped.sample_count == truth.rate.size
    assert list(workdir.iterdir()) == []


def test_paced_in_rig_time(tmp_path: Path) -> None:
    _, path = small_session(tmp_path)
    mono = ManualClock(100.0)
    source = SimSource(session_file_trials(path), RigClock(START_NS, 20.0, monotonic=mono), pause_between_trials_s=1.0)
    first = source.poll()  # rig time START_NS: the START and the first sample
    assert isinstance(first[0], TrialStarted) and first[0].stamp_ns == START_NS
    assert sum(e.rates.size for e in first if isinstance(e, SampleBlock)) == 1
    mono.now += 0.01  # 0.2 s of rig time
    more = source.poll()
    assert sum(e.rates.size for e in more if isinstance(e, SampleBlock)) == 200
    mono.now += TRIAL_S / 20  # past the end of the first trial, not yet the pause's
    end = source.poll()
    assert isinstance(end[-1], TrialStopped) and end[-1].sample_count == 6000
    mono.now += 0.5 / 20  # half the pause: nothing
    assert source.poll() == []
    mono.now += 0.5 / 20  # the second trial starts
    assert isinstance(source.poll()[0], TrialStarted)


def test_sim_declines_trial_requests(tmp_path: Path) -> None:
    _, path = small_session(tmp_path)
    source = SimSource(session_file_trials(path))
    with pytest.raises(TrialRequestError, match="walks its own plan"):
        source.start_trial(TrialRequest("frame", "compound", duration_s=1.0))
    with pytest.raises(TrialRequestError, match="walks its own plan"):
        source.stop_trial()


@pytest.mark.parametrize(
    ("parameters", "pattern"),
    [
        ({}, r"^sim source: parameter 'session' = '': the sim source needs 'session' .* or 'bicycle'"),
        (
            {"session": "nowhere/session.yaml"},
            r"^sim source: parameter 'session' = 'nowhere/session.yaml': no such file$",
        ),
        ({"session": "S", "bicycle": "B"}, r"^sim source: parameter 'bicycle' = 'B': give either 'session' \(S\)"),
        ({"bicycle": "nowhere.yaml"}, r"^sim source: parameter 'bicycle' = 'nowhere.yaml': nowhere.yaml: "),
        ({"bicycle": str(BICYCLE), "rig": "norig.yaml"}, r"^sim source: parameter 'rig' = 'norig.yaml': norig.yaml: "),
        ({"bicycle": str(BICYCLE), "seed": -1}, r"^sim source: parameter 'seed' = -1: must be >= 0$"),
        ({"session": "S", "time_scale": 0.0}, r"^sim source: parameter 'time_scale' = 0.0: must be >= 0.001$"),
        ({"session": "S", "time_scale": 5000.0}, r"^sim source: parameter 'time_scale' = 5000.0: must be <= 1000$"),
        ({"session": "S", "pause_between_trials_s": -1.0}, r"'pause_between_trials_s' = -1.0: must be >= 0$"),
        ({"session": 3}, r"^sim source: parameter 'session' = 3: expected a string$"),
    ],
)
def test_bad_configuration_is_one_clear_error(parameters: dict[str, object], pattern: str) -> None:
    with pytest.raises(SourceConfigError, match=pattern) as info:
        open_source("sim", parameters)
    assert "\n" not in str(info.value)


def test_a_broken_session_names_the_file_the_key_and_the_line(tmp_path: Path) -> None:
    _, path = small_session(tmp_path)
    (path.parent / "trials" / "frame_compound_t1.npy").unlink()
    with pytest.raises(SourceConfigError) as info:
        open_source("sim", session=str(path))
    message = str(info.value)
    assert message.startswith(f"sim source: parameter 'session' = '{path}': session.yaml:")
    assert "key 'frame.compound_period'" in message and "frame_compound_t1.npy" in message
    assert "no such file" in message

    other = tmp_path / "other.yaml"
    other.write_text("format: bike_rig-rig/1\n", encoding="utf-8")
    with pytest.raises(SourceConfigError, match="not a session file"):
        open_source("sim", session=str(other))


def test_unevenly_sampled_trial_files_are_refused(tmp_path: Path) -> None:
    _, path = small_session(tmp_path)
    trial = path.parent / "trials" / "rear_wheel_compound_t1.npy"
    data = np.load(trial)
    data[100:, 0] += 0.0005  # a timing jump
    np.save(trial, data)
    with pytest.raises(SourceConfigError, match="rear_wheel_compound_t1.npy: the times are not evenly spaced"):
        open_source("sim", session=str(path))
