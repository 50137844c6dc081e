"""Tests of ``replay --republish``: a bag played back into a live graph and recorded again.

A bag's raw stream played back into a live graph (real processes), and recorded again by the
recorder: the same bytes, in the same order, with the timing scaled.
"""

from __future__ import annotations

import dataclasses
import re
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
    # timing. The republisher sleeps (on the monotonic clock) until each message is due, wall0 +
    # (log offset from the bag's first message) / RATE_SCALE, and then publishes it; it prints
    # its wall time, the bag span and its largest lag L (how late it found itself at a message).
    # Load can only delay a send, never bring it forward, so what is asserted are lower bounds:
    found = re.search(r" in ([0-9.]+) s \(bag span ([0-9.]+) s, .*, largest lag ([0-9.]+) ms\)", summary)
    assert found, summary
    wall_s, bag_span_s, lag_s = float(found[1]), float(found[2]), float(found[3]) / 1e3
    # the playback took at least the bag's span, scaled (both printed to 0.01 s)
    assert wall_s >= bag_span_s / RATE_SCALE - 0.01, summary
    # the send times (DDS source stamps, which the recorder keeps as MCAP publish times):
    # gyro batch k is sent no earlier than it is due. Relative to the first batch's send s0:
    # s0 came before the republisher looked at the next message (the second batch at the latest,
    # due at offset t1), which it found at most L late, so s0 <= wall0 + t1 / RATE_SCALE + L and
    # sent_k - s0 >= (t_k - t1) / RATE_SCALE - L. (eps: L is printed to 0.1 ms, and the source
    # stamps' realtime clock may be slewed against the monotonic one by at most 500 ppm.)
    scan = scan_mcap(copy / "copy_0.mcap")
    gyro_id = next(cid for cid, ch in scan.channels.items() if ch.topic == GYRO.name)
    sent = [m.publish_time for m in scan.messages if m.channel_id == gyro_id]
    log_times = [t for t, _ in original[GYRO.name]]
    assert len(sent) == len(log_times)
    span = (log_times[-1] - log_times[0]) / 1e9 / RATE_SCALE
    assert span > 2.0  # a burst (all sent at once) could not pass below unless reported that late
    s0, t1 = sent[0], log_times[1]
    eps = 1e-4 + 500e-6 * (max(sent) - s0) / 1e9
    early = [
        (k, (s - s0) / 1e9, (t - t1) / 1e9 / RATE_SCALE)
        for k, (s, t) in enumerate(zip(sent, log_times))
        if k > 0 and (s - s0) / 1e9 < (t - t1) / 1e9 / RATE_SCALE - lag_s - eps
    ]
    assert not early, (len(early), early[:5], summary)
    # and each was received after it was sent (one host, one clock)
    delays = [(r - s) / 1e9 for (r, _), s in zip(replayed[GYRO.name], sent)]
    assert min(delays) >= 0, min(delays)
