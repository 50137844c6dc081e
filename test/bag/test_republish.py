"""Tests of ``replay --republish``: a bag played back into a live graph and recorded again.

A bag's raw stream played back into a live graph (real processes), and recorded again by the
recorder: the same bytes, in the same order, with the timing scaled.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import pytest

from bike_rig.bag.reader import open_bag
from bike_rig.bag.recover import scan_mcap
from bike_rig.bag.simulated import write_simulated_bag
from bike_rig.config.topics import GYRO, STATIC_READINGS, TRIAL_EVENTS
from bike_rig.core.sim import SimulatedSession
from test.support.nodes import node_environment
from test.support.probe import STEP_TIMEOUT_S
from test.support.processes import RosProcess
from test.support.recorder import start_recorder, wait_for_data

pytestmark = pytest.mark.ros

RATE_SCALE = 10.0


def test_republished_stream_is_recorded_identically(
    session: SimulatedSession, ros_env: dict[str, str], tmp_path: Path
) -> None:
    env = node_environment(ros_env)
    two_trials = dataclasses.replace(session, trials=session.trials[:2])
    source = write_simulated_bag(tmp_path / "source", two_trials, pause_s=1.0)
    with open_bag(source) as b:
        original = {
            t: [(m.log_time, m.data) for m in b.messages([t])]
            for t in (STATIC_READINGS.name, TRIAL_EVENTS.name, GYRO.name)
        }
    expected = {t: len(v) for t, v in original.items()}
    copy = tmp_path / "copy"
    argv = [
        sys.executable,
        "-m",
        "bike_rig.ros.republish",
        str(source),
        "--rate-scale",
        str(RATE_SCALE),
        "--wait",
        str(STEP_TIMEOUT_S),
    ]
    with start_recorder(tmp_path, env, copy, "topics:=[gyro, trial_events, static_readings]") as rec:
        with RosProcess("republish", argv, env, tmp_path) as pub:
            summary = pub.expect("published", STEP_TIMEOUT_S)
            assert pub.proc.wait(timeout=STEP_TIMEOUT_S) == 0, pub.describe()
        wait_for_data(copy, expected, rec)
        assert rec.stop() == 0, rec.describe()
    assert summary.startswith(f"{sum(expected.values())} messages of {source}"), summary

    with open_bag(copy) as b:
        replayed = {t: [(m.log_time, m.data) for m in b.messages([t])] for t in original}
    for topic in original:
        # the same bytes in the same order; DDS pads a payload to a multiple of 4 bytes (a
        # bag recorded from DDS holds padded payloads already, so they round-trip unchanged)
        padded = [d + b"\0" * (-len(d) % 4) for _, d in original[topic]]
        assert [d for _, d in replayed[topic]] == padded, topic
    # timing: the republisher's send times (the MCAP publish times the recorder keeps),
    # relative to the first, are the original log times' offsets divided by RATE_SCALE
    scan = scan_mcap(copy / "copy_0.mcap")
    gyro_id = next(cid for cid, ch in scan.channels.items() if ch.topic == GYRO.name)
    sent = [m.publish_time for m in scan.messages if m.channel_id == gyro_id]
    t0, s0 = original[GYRO.name][0][0], sent[0]
    lags = [(s - s0) / 1e9 - (t - t0) / 1e9 / RATE_SCALE for (t, _), s in zip(original[GYRO.name], sent)]
    span = (original[GYRO.name][-1][0] - t0) / 1e9 / RATE_SCALE
    assert span > 2.0
    # paced, not bursted: the typical message on its time (a loaded machine may delay a few)
    assert sorted(abs(x) for x in lags)[len(lags) // 2] < 0.25, (min(lags), max(lags))
    assert abs((sent[-1] - s0) / 1e9 - span) < 0.25 * span + 1.0, ((sent[-1] - s0) / 1e9, span)
    # and they were received right away
    delays = sorted((r - s) / 1e9 for (r, _), s in zip(replayed[GYRO.name], sent))
    assert delays[0] >= 0 and delays[len(delays) // 2] < 1.0, (delays[0], delays[len(delays) // 2], delays[-1])
