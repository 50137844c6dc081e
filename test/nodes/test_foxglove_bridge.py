"""The Foxglove bridge node as a real process, seen through Foxglove's WebSocket protocol.

The test's own ROS node publishes a small session on the rig's topics (a trial's events and
gyro batches, its period, the Browser's parameters of ``../shared``, an eigen sweep, and
diagnostics when ``diagnostic_msgs`` is installed); a protocol client
(:mod:`test.support.foxglove_client`) subscribes to every channel the bridge advertises and
decodes each payload with the rig's typestore: every message arrives with the content
published, on a channel whose schema is the type's ``ros2msg`` definition. A client that
connects afterwards gets the transient-local topics' messages again, not the gyro batches.
"""

from __future__ import annotations

import importlib
import socket
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from bike_rig.bag.typestore import message_definition, store_for
from bike_rig.config.topics import EIGEN_SWEEP, GYRO, PARAMETERS, PERIODS, TRIAL_EVENTS
from bike_rig.core.loader import load_input
from bike_rig.ros.liveview import DIAGNOSTICS, VIEW_TOPICS
from test.support.foxglove_client import foxglove_client
from test.support.probe import STEP_TIMEOUT_S, Probe, msgs, node_command
from test.support.processes import RosProcess

pytest.importorskip("foxglove")

TRIAL = "frame_torsional_o1_t1"
RATE = 1000.0
BATCH = 50
N_BATCHES = 12


def _diagnostics_module() -> Any | None:
    try:
        return importlib.import_module("diagnostic_msgs.msg")
    except ImportError:
        return None


def free_port() -> int:
    """A TCP port nobody listens on now (the OS's choice)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _stamp(msg: Any, ns: int) -> None:
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 1_000_000_000)


def session_messages(shared_dir: Path) -> dict[str, list[Any]]:
    """One trial's worth of every view topic, as rclpy messages, in publication order per topic."""
    rng = np.random.default_rng(15)
    t0 = 1_780_000_000_000_000_000
    rates = 0.3 * np.sin(2 * np.pi * np.arange(N_BATCHES * BATCH) / RATE / 1.7) + 1e-3 * rng.standard_normal(
        N_BATCHES * BATCH
    )
    events = []
    for kind, count in ((msgs.TrialEvent.START, 0), (msgs.TrialEvent.STOP, rates.size)):
        e = msgs.TrialEvent(
            kind=kind,
            trial_id=TRIAL,
            part="frame",
            pendulum="torsional",
            orientation=1,
            repeat=1,
            measurement_key="TtB1",
            sample_rate_hz=RATE,
            sample_count=count,
        )
        _stamp(e, t0 + (0 if kind == msgs.TrialEvent.START else int(rates.size / RATE * 1e9)))
        events.append(e)
    batches = []
    for i in range(N_BATCHES):
        b = msgs.GyroBatch(
            trial_id=TRIAL,
            first_index=i * BATCH,
            sample_rate_hz=RATE,
            rates=rates[i * BATCH : (i + 1) * BATCH].tolist(),
        )
        _stamp(b, t0 + int(i * BATCH / RATE * 1e9))
        batches.append(b)
    period = msgs.PeriodEstimate(
        trial_id=TRIAL,
        measurement_key="TtB1",
        period=1.7,
        period_sigma=2e-4,
        zeta=1e-3,
        omega=2 * np.pi / 1.7,
        r2=0.999,
        n_samples=rates.size,
        n_expected=rates.size,
        valid=True,
        flags=["short"],
        flag_reasons=["a short record"],
    )
    browser = load_input(str(shared_dir / "data/bicycleparameters/Browser/Parameters/BrowserBenchmark.txt"))
    pv = browser.parameters  # type: ignore[union-attr]
    params = msgs.BenchmarkParameters(
        bicycle="Browser",
        names=list(pv.names),
        values=[pv.value(k) for k in pv.names],
        sigmas=[pv.sigma(k) for k in pv.names],
        complete=True,
    )
    speeds = np.linspace(0.0, 10.0, 21)
    eig = rng.standard_normal((speeds.size, 4))
    sweep = msgs.EigenSweep(
        bicycle="Browser",
        speeds=speeds.tolist(),
        eigenvalues_real=eig.ravel().tolist(),
        eigenvalues_imag=(0.5 * eig).ravel().tolist(),
        mode_labels=["weave", "weave", "capsize", "caster"],
        has_weave=True,
        weave_speed=4.3,
        weave_speed_sigma=0.05,
        has_capsize=True,
        capsize_speed=6.1,
        capsize_speed_sigma=0.04,
    )
    out = {
        TRIAL_EVENTS.name: events,
        GYRO.name: batches,
        PERIODS.name: [period],
        PARAMETERS.name: [params],
        EIGEN_SWEEP.name: [sweep],
    }
    diag = _diagnostics_module()
    if diag is not None:
        status = diag.DiagnosticStatus(
            level=diag.DiagnosticStatus.WARN,
            name="driver: sample rate",
            message="999.0 Hz of 1000",
            hardware_id="rig",
            values=[diag.KeyValue(key="rate_hz", value="999.0")],
        )
        array = diag.DiagnosticArray(status=[status])
        _stamp(array, t0)
        out[DIAGNOSTICS.name] = [array]
    return out


def assert_same(decoded: Any, published: Any, where: str) -> None:
    """Every field of a rosbags-decoded message equals the rclpy message's (recursively)."""
    for name in published.get_fields_and_field_types():
        got, want = getattr(decoded, name), getattr(published, name)
        if isinstance(want, bytes) and len(want) == 1:  # a ROS byte (rclpy: bytes; rosbags: an integer)
            want = want[0]
        if hasattr(want, "get_fields_and_field_types"):
            assert_same(got, want, f"{where}.{name}")
        elif isinstance(want, (list, tuple)) and want and hasattr(want[0], "get_fields_and_field_types"):
            assert len(got) == len(want), f"{where}.{name}: {len(got)} items, published {len(want)}"
            for i, (g, w) in enumerate(zip(got, want, strict=True)):
                assert_same(g, w, f"{where}.{name}[{i}]")
        elif isinstance(got, np.ndarray) or not isinstance(want, (str, bool, int, float)):
            assert np.array_equal(np.asarray(got), np.asarray(want)), f"{where}.{name}: {got!r} != {want!r}"
        else:
            assert got == want, f"{where}.{name}: {got!r} != {want!r}"


@pytest.fixture
def bridge(ros_env: dict[str, str], tmp_path: Path) -> Iterator[tuple[RosProcess, str]]:
    """The bridge node as a process on a free port, and its ``ws://`` address."""
    port = free_port()
    cmd = node_command("bike_rig.ros.nodes.foxglove_bridge", f"port:={port}")
    with RosProcess("foxglove_bridge", cmd, ros_env, tmp_path) as proc:
        yield proc, f"ws://127.0.0.1:{port}"


def _topic_types() -> dict[str, str]:
    return {v.name: v.type for v in VIEW_TOPICS}


#: The trial id (gyro) and status name (diagnostics) of the messages that only show a subscription is in effect.
SENTINEL = "sentinel"


def _sentinel(topic: str) -> Any:
    """A message of a live-only topic that is not the session's."""
    if topic == GYRO.name:
        return msgs.GyroBatch(trial_id=SENTINEL, first_index=0, sample_rate_hz=RATE, rates=[0.0] * BATCH)
    diag = _diagnostics_module()
    assert diag is not None and topic == DIAGNOSTICS.name, topic
    return diag.DiagnosticArray(status=[diag.DiagnosticStatus(name=SENTINEL)])


def _is_sentinel(topic: str, rec: Any) -> bool:
    if topic not in (GYRO.name, DIAGNOSTICS.name):
        return False
    msgtype = _topic_types()[topic]
    msg = store_for(msgtype).deserialize_cdr(rec.payload, msgtype)
    return bool(msg.trial_id == SENTINEL) if topic == GYRO.name else any(st.name == SENTINEL for st in msg.status)


def _counted(client: Any) -> dict[str, int]:
    """The messages received per topic, sentinels left out."""
    return {t: sum(not _is_sentinel(t, r) for r in v) for t, v in client.received.items()}


def _await_live_subscriptions(client: Any, publishers: dict[str, Any], proc: RosProcess) -> None:
    """Publish sentinels on the live-only topics until one of each reaches ``client``.

    A live-only topic (no backlog) forwards only what is published once the bridge has taken the
    subscription; the session's messages, published after the sentinels on the same publishers,
    arrive after them (one publisher's messages stay in order), so none is published too early.
    """
    live = [t for t in (GYRO.name, DIAGNOSTICS.name) if t in publishers]
    deadline = time.monotonic() + STEP_TIMEOUT_S
    while not all(any(_is_sentinel(t, r) for r in client.received.get(t, [])) for t in live):
        assert time.monotonic() < deadline, f"no sentinel forwarded within {STEP_TIMEOUT_S} s\n{proc.describe()}"
        for t in live:
            publishers[t].publish(_sentinel(t))
        client.drain(0.1)


def test_every_channel_carries_what_was_published(
    probe: Probe, bridge: tuple[RosProcess, str], shared_dir: Path
) -> None:
    proc, url = bridge
    session = session_messages(shared_dir)
    publishers = {
        name: probe.publisher(next(v.topic for v in VIEW_TOPICS if v.name == name), type(ms[0]))
        for name, ms in session.items()
    }
    probe.spin_until(
        lambda: all(p.get_subscription_count() > 0 for p in publishers.values()),
        STEP_TIMEOUT_S,
        "bridge subscription on every topic",
        proc.describe,
    )

    with foxglove_client(url) as client:
        served = {v.name for v in VIEW_TOPICS if v.name != DIAGNOSTICS.name or _diagnostics_module() is not None}
        client.read_until(lambda: set(client.by_topic()) == served, STEP_TIMEOUT_S, "advertise of every topic")
        assert client.server_info is not None and client.ws.subprotocol in ("foxglove.sdk.v1", "foxglove.websocket.v1")
        for topic, channel in client.by_topic().items():
            msgtype = _topic_types()[topic]
            assert (channel["encoding"], channel["schemaName"], channel["schemaEncoding"]) == (
                "cdr",
                msgtype,
                "ros2msg",
            ), topic
            assert channel["schema"] == message_definition(msgtype), f"{topic}: not the recorder's schema text"
        client.subscribe(session)
        _await_live_subscriptions(client, publishers, proc)  # (before anything counted is published)
        for name in (TRIAL_EVENTS.name, GYRO.name, PERIODS.name, PARAMETERS.name, EIGEN_SWEEP.name, DIAGNOSTICS.name):
            for msg in session.get(name, []):
                publishers[name].publish(msg)
        want = {name: len(ms) for name, ms in session.items()}
        client.read_until(lambda: _counted(client) == want, STEP_TIMEOUT_S, f"every message ({want})")
        received = {t: [r for r in v if not _is_sentinel(t, r)] for t, v in client.received.items()}
        for topic, published in session.items():
            msgtype = _topic_types()[topic]
            store = store_for(msgtype)
            for i, (rec, msg) in enumerate(zip(received[topic], published, strict=True)):
                assert_same(store.deserialize_cdr(rec.payload, msgtype), msg, f"{topic}[{i}]")
        gyro = [store_for(GYRO.type).deserialize_cdr(r.payload, GYRO.type) for r in received[GYRO.name]]
        sent = np.concatenate([np.asarray(b.rates) for b in session[GYRO.name]])
        assert np.array_equal(np.concatenate([g.rates for g in gyro]), sent)  # the whole trace, in order

    with foxglove_client(url) as late:
        late.read_until(lambda: GYRO.name in late.by_topic(), STEP_TIMEOUT_S, "advertise")
        late.subscribe(session)
        kept = {name: len(ms) for name, ms in session.items() if name not in (GYRO.name, DIAGNOSTICS.name)}
        late.read_until(
            lambda: all(len(late.received.get(t, [])) == n for t, n in kept.items()),
            STEP_TIMEOUT_S,
            f"the kept messages ({kept})",
        )
        late.drain(1.0)
        assert GYRO.name not in late.received, "gyro batches are live only"
        for topic, n in kept.items():
            assert len(late.received[topic]) == n, topic
            msgtype = _topic_types()[topic]
            for rec, msg in zip(late.received[topic], session[topic], strict=True):
                assert_same(store_for(msgtype).deserialize_cdr(rec.payload, msgtype), msg, f"late {topic}")
    assert proc.stop() == 0, proc.describe()
    log = proc.stderr_path.read_text()
    assert "Callback failed" not in log and "not forwarded" not in log, log  # (the SDK's and ours)
    if _diagnostics_module() is None:
        assert "/diagnostics not served: diagnostic_msgs/msg/DiagnosticArray is not installed" in log


def test_a_taken_port_is_one_line_and_status_2(ros_env: dict[str, str], tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        cmd = node_command("bike_rig.ros.nodes.foxglove_bridge", f"port:={port}")
        with RosProcess("foxglove_bridge", cmd, ros_env, tmp_path) as proc:
            code = proc.proc.wait(timeout=STEP_TIMEOUT_S)
    err = proc.stderr_path.read_text().strip().splitlines()
    assert code == 2, proc.describe()
    assert err[-1].startswith(f"foxglove_bridge: error: cannot serve the live view on 127.0.0.1:{port}"), err
    assert "Traceback" not in "\n".join(err)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--port", "70000"], "--port must be within 0..65535, got 70000"),
        (["--domain-id", "150"], "--domain-id"),
    ],
)
def test_bad_view_arguments_end_in_one_line(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    from bike_rig.cli.main import main

    assert main(["view", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bike-rig view: error:") and message in err[0], err


def test_a_late_client_gets_the_whole_kept_history(probe: Probe, bridge: tuple[RosProcess, str]) -> None:
    """The whole kept history (2000 trial events, above the SDK's default backlog) reaches a later client, in order."""
    proc, url = bridge
    n = TRIAL_EVENTS.qos.depth  # the whole transient-local history
    pub = probe.publisher(TRIAL_EVENTS, msgs.TrialEvent)
    probe.spin_until(lambda: pub.get_subscription_count() > 0, STEP_TIMEOUT_S, "the bridge", proc.describe)
    for i in range(n):
        pub.publish(msgs.TrialEvent(trial_id=f"t{i}", measurement_key="TtB1", sample_rate_hz=RATE))
    with foxglove_client(url) as client:
        client.read_until(lambda: TRIAL_EVENTS.name in client.by_topic(), STEP_TIMEOUT_S, "advertise")
        # (those the bridge has not taken from DDS yet come live, after the replay: the order holds)
        client.subscribe([TRIAL_EVENTS.name])
        client.read_until(
            lambda: len(client.received.get(TRIAL_EVENTS.name, [])) >= n, STEP_TIMEOUT_S, f"{n} kept trial events"
        )
    store = store_for(TRIAL_EVENTS.type)
    ids = [store.deserialize_cdr(r.payload, TRIAL_EVENTS.type).trial_id for r in client.received[TRIAL_EVENTS.name]]
    assert ids == [f"t{i}" for i in range(n)]
