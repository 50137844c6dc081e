"""Static readings entered during a live session: the parameter node and the recorder as real processes.

The parameter node starts from the bicycle's name alone. The test's rclpy node (the console's
stand-in) enters every static reading on ``/bike_rig/readings`` (one in grams by mistake, two
that cannot be used) and publishes a simulated session's trials and their period estimates.
The node names what is missing, readings and periods; completes the set; a correction changes
it; the recorder's bag holds every entry, and replays with no other file to the offline core.
"""

from __future__ import annotations

import subprocess
import sys
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bike_rig.bag.recover import scan_mcap
from bike_rig.bag.simulated import live_results, simulated_messages
from bike_rig.bag.typestore import rig_typestore
from bike_rig.config import topics
from bike_rig.core.benchmark import compute_parameters
from bike_rig.core.measurements import Measurements
from bike_rig.messages import (
    fill_reading_entry,
    reading_entry_from_msg,
    session_parameters_from_msg,
    static_readings_from_msg,
    trial_fit_from_msg,
)
from bike_rig.offline.compare import relative_difference
from bike_rig.offline.replay import replay_bag
from bike_rig.offline.session import read_session
from bike_rig.pipeline.assemble import SessionParameters, assemble
from bike_rig.pipeline.readings import ReadingEntry, apply_entries
from test.support.entered import MISTAKE_KEY, one_trial_session, operator_entries
from test.support.nodes import BROWSER, BROWSER_KEYS, STATIC_KEYS, start_node
from test.support.probe import Probe
from test.support.recorder import wait_for_data
from test.support.replay import core_periods
from test.support.wait import wait_until

pytestmark = pytest.mark.ros

START_NS = 1_800_000_000 * 1_000_000_000
#: Entered last: the set stays incomplete, missing exactly these.
LATE = ("mF", "aH3")


def publisher(probe: Probe, topic: topics.Topic, msg_type: Any, subscribers: int) -> Any:
    """The probe's publisher on ``topic``, once ``subscribers`` subscriptions have matched."""
    pub = probe.publisher(topic, msg_type)
    probe.wait_for(lambda: pub.get_subscription_count() >= subscribers, f"{subscribers} subscribers of {topic.name}")
    return pub


def enter(pub: Any, entries: list[ReadingEntry]) -> None:
    from bike_rig_msgs.msg import ReadingEntry as ReadingEntryMsg

    for e in entries:
        pub.publish(fill_reading_entry(ReadingEntryMsg(), e))


def expected_set(entries: list[ReadingEntry], estimates: list[Any]) -> SessionParameters:
    """What the offline core assembles from the same entries and period estimates."""
    static = apply_entries(Measurements("Browser", {}, ""), entries)
    return assemble(static, [trial_fit_from_msg(e.message) for e in estimates])


def assert_same(msg: Any, expected: SessionParameters) -> None:
    got = session_parameters_from_msg(msg)
    assert got.complete and expected.parameters is not None and got.parameters is not None
    assert got.periods == expected.periods
    assert np.array_equal(got.parameters.parameters.values, expected.parameters.parameters.values)
    assert np.array_equal(got.parameters.parameters.covariance, expected.parameters.parameters.covariance)


def publish_trials(probe: Probe, messages: list[Any]) -> None:
    """Publish the trials' events and batches (to the recorder) and their estimates (to the node too), as CDR."""
    from bike_rig_msgs.msg import GyroBatch, PeriodEstimate, TrialEvent

    kinds = ((topics.TRIAL_EVENTS, TrialEvent, 1), (topics.GYRO, GyroBatch, 1), (topics.PERIODS, PeriodEstimate, 2))
    raw = {t.name: publisher(probe, t, cls, n) for t, cls, n in kinds}
    store, types = rig_typestore(), {t.name: t.type for t in topics.TOPICS}
    for m in messages:
        raw[m.topic].publish(bytes(store.serialize_cdr(m.message, types[m.topic])))


def check_bag(bag: Path, published: list[ReadingEntry], used: int, session: Any) -> None:
    """The bag holds every entry (a reading and its correction) and replays with no file to the offline core.

    Args:
        bag: The recorded bag.
        published: Every entry published (those the node refused too).
        used: How many of them the node applied.
        session: The simulated session.
    """

    def order(e: ReadingEntry) -> tuple[int, str]:
        return (e.stamp_ns, e.key)

    recorded = [reading_entry_from_msg(m) for m in read_session(bag).reading_entries]
    assert sorted(recorded, key=order) == sorted(published, key=order)
    true_mr = session.readings[MISTAKE_KEY].value
    mistake = [(e.value, e.note) for e in recorded if e.key == MISTAKE_KEY]
    assert mistake == [(1000 * true_mr, ""), (true_mr, "correction")]
    result = replay_bag(bag)
    assert result.complete and result.readings == f"{used} reading entries"
    core = compute_parameters(session.measurements(core_periods(session))).parameters
    ours = result.parameters
    assert ours is not None and list(ours.parameters.names) == list(core.names)
    assert relative_difference(ours.parameters.values, core.values)[0] <= 1e-12
    assert relative_difference(ours.parameters.covariance, core.covariance)[0] <= 1e-12
    assert result.live.identical and result.live.compared_trials == len(session.trials), result.live.worst


def wait_for_static_source(bag: Path, source: str, recorder: Any, timeout_s: float = 30.0) -> None:
    """Wait until the recorder's flushed chunks hold a ``StaticReadings`` with this ``source``."""
    data = bag / f"{bag.name}_0.mcap"
    store = rig_typestore()
    seen: list[str] = []

    def recorded() -> bool:
        assert recorder.proc.poll() is None, recorder.describe()
        if not data.exists():
            return False
        scan = scan_mcap(data)
        ids = {cid for cid, ch in scan.channels.items() if ch.topic == topics.STATIC_READINGS.name}
        seen[:] = [
            str(store.deserialize_cdr(m.data, "bike_rig_msgs/msg/StaticReadings").source)
            for m in scan.messages
            if m.channel_id in ids
        ]
        return source in seen

    wait_until(
        recorded,
        f"StaticReadings from {source!r} recorded",
        timeout_s,
        0.1,
        lambda: f"recorded StaticReadings sources {seen}\n{recorder.describe()}",
    )


def test_readings_entered_live_complete_correct_record_and_replay(
    probe: Probe, node_env: dict[str, str], tmp_path: Path
) -> None:
    from bike_rig_msgs.msg import BenchmarkParameters, StaticReadings
    from bike_rig_msgs.msg import ReadingEntry as ReadingEntryMsg

    session = one_trial_session()
    stream = [
        m for m in simulated_messages(session, start_ns=START_NS, pause_s=0.5) if m.topic != topics.STATIC_READINGS.name
    ]
    # the fitter's estimates (no static readings: periods only; not their details)
    estimates = [m for m in live_results(stream) if m.topic == topics.PERIODS.name]
    entries = operator_entries(session, START_NS - 100 * 1_000_000_000)
    correction = entries[-1]
    early = [e for e in entries[:-1] if e.key not in LATE]
    late = [e for e in entries[:-1] if e.key in LATE]
    bad = [ReadingEntry("mX", 1.0, 0.1, START_NS), ReadingEntry("mF", -2.0, 0.02, START_NS + 1)]
    static_box = probe.listen(topics.STATIC_READINGS, StaticReadings)
    params_box = probe.listen(topics.PARAMETERS, BenchmarkParameters)
    bag = tmp_path / "bag"
    with (
        start_node("recorder", "recorder", node_env, tmp_path, "-p", f"output:={bag}") as recorder,
        start_node("parameter", "parameter", node_env, tmp_path, "-p", "bicycle:=Browser") as node,
    ):
        procs = [node, recorder]
        first = probe.wait_message(topics.PARAMETERS, lambda m: True, "the first status", procs)
        assert not first.complete and tuple(first.missing) == STATIC_KEYS + BROWSER_KEYS
        # (another topic: it may come after the first status)
        probe.wait_message(topics.STATIC_READINGS, lambda m: True, "the first static readings", procs)
        assert static_box[0].bicycle == "Browser" and len(static_box[0].keys) == 0

        readings = publisher(probe, topics.READINGS, ReadingEntryMsg, 2)  # the node and the recorder
        enter(readings, [*bad, *early])
        publish_trials(probe, [*stream, *estimates])

        status = probe.wait_message(
            topics.PARAMETERS, lambda m: tuple(m.missing) == LATE, f"the status missing only {LATE}", procs
        )
        assert not status.complete and list(status.period_keys) == list(BROWSER_KEYS)
        merged_msg = probe.wait_message(
            topics.STATIC_READINGS, lambda m: m.source == f"{len(early)} reading entries", "the merged readings", procs
        )
        merged = static_readings_from_msg(merged_msg)
        assert set(merged.readings) == set(STATIC_KEYS) - set(LATE)

        enter(readings, late)  # mR in grams: a rear wheel no rigid body can be, refused, never published
        refused = lambda: "not physically possible" in node.stderr_path.read_text()  # noqa: E731
        wait_until(refused, "the refusal", 60, describe=node.describe)
        enter(readings, [correction])
        fixed = probe.wait_message(
            topics.PARAMETERS,
            lambda m: m.complete and m.values[list(m.names).index("mR")] == correction.value,
            "the set with the corrected reading",
            procs,
        )
        assert_same(fixed, expected_set([*early, *late, correction], estimates))
        mr = list(fixed.names).index("mR")
        assert not [m for m in params_box if m.complete and m.values[mr] != correction.value]  # (none impossible)
        last_msg = probe.wait_message(
            topics.STATIC_READINGS,
            lambda m: m.source == f"{len(entries)} reading entries",
            "the corrected readings",
            procs,
        )
        last = static_readings_from_msg(last_msg)
        assert list(last.readings) == list(STATIC_KEYS) and last.value(MISTAKE_KEY) == correction.value
        assert "rear_wheel:" in last_msg.document and repr(correction.value) in last_msg.document
        # everything published is in the recorder's flushed chunks (a reliable repair may take a heartbeat),
        # the node's last StaticReadings too: stopped before, its writer could no longer repair it
        counts = Counter(m.topic for m in [*stream, *estimates])
        counts[topics.READINGS.name] = len(bad) + len(entries)
        wait_for_data(bag, counts, recorder)
        wait_for_static_source(bag, last_msg.source, recorder)
        assert node.stop() == 0, node.describe()
        assert recorder.stop() == 0, recorder.describe()

    # two bad entries: one warning line each, the node kept going
    warnings = [line for line in node.stderr_path.read_text().splitlines() if "reading entry ignored" in line]
    assert len(warnings) == 2, node.describe()
    assert "unknown key 'mX'" in warnings[0] and "must be positive" in warnings[1]
    assert len(params_box) >= 3

    check_bag(bag, [*bad, *entries], len(entries), session)


@pytest.mark.parametrize(
    ("params", "expected"),
    [
        ((), "give parameter 'measurements' (the bicycle's measurement file"),
        (
            ("-p", f"measurements:={BROWSER}", "-p", "bicycle:=Fisher"),
            "parameter 'bicycle' = 'Fisher': the measurement file",
        ),
    ],
)
def test_neither_file_nor_name_or_a_name_not_the_files_is_one_error_line(
    node_env: dict[str, str], tmp_path: Path, params: tuple[str, ...], expected: str
) -> None:
    argv = [sys.executable, "-m", "bike_rig.ros.nodes.parameter", "--ros-args", *params]
    done = subprocess.run(argv, env=node_env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("parameter: error: ") and expected in lines[0], done.stderr
