"""The live view in Foxglove with real processes: ``bike-rig run --config graph_view.yaml`` and ``bike-rig view``.

The shipped graph with the bridge (the simulated rig → fitter → parameter → model, recorder,
Foxglove bridge) on the short rig of :mod:`test.cli.test_run_live`; a Foxglove protocol client
(:mod:`test.support.foxglove_client`) subscribes to every channel while the session runs. What
it receives is what the recorder recorded, byte for byte (both take the CDR that DDS
delivers): the gyro batches it got are the bag's from the first it got to the last, in the
bag's order, each trial that started after it subscribed whole; the trial events and periods
are the bag's, in its order (those before the client subscribed come from the bridge's kept
history); the latest parameters, matrices and
eigen sweep are the bag's latest (latched, depth 1: either reader may skip a set replaced
before it was delivered); the bag's MCAP schemas are those the bridge advertises. ``bike-rig view`` on an empty domain
serves clients of both protocol names (the Python client offering ``foxglove.sdk.v1`` and
``foxglove.websocket.v1``, then only the latter, and the official ``@foxglove/ws-protocol``
client when tools/setup_node.sh has installed it) and says that no graph is there.
"""

from __future__ import annotations

import json
import socket
import subprocess
import time
from pathlib import Path

from mcap.reader import make_reader
from rosbags.rosbag2 import Reader

from bike_rig.bag.typestore import rig_typestore
from bike_rig.config.topics import EIGEN_SWEEP, GYRO, MATRICES, PARAMETERS, PERIODS, TRIAL_EVENTS
from bike_rig.ros.liveview import DIAGNOSTICS, VIEW_TOPICS
from bike_rig.ros.nodes.foxglove_relay import LEGACY_SUBPROTOCOL, SUBPROTOCOLS
from test.support.foxglove_client import foxglove_client, official_client
from test.support.live import all_lines as _all_lines
from test.support.live import bike_rig_argv as _bike_rig
from test.support.live import live_rig as _rig
from test.support.processes import RosProcess


def free_port() -> int:
    """A TCP port nobody listens on now (the OS's choice)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _bag_payloads(bag: Path) -> dict[str, list[bytes]]:
    out: dict[str, list[bytes]] = {}
    with Reader(bag) as reader:
        for connection, _, raw in reader.messages():
            out.setdefault(connection.topic, []).append(bytes(raw))
    return out


def test_a_run_with_the_view_serves_what_the_bag_records(ros_env: dict[str, str], tmp_path: Path) -> None:
    _rig(tmp_path, beating=False)
    port = free_port()
    cmd = _bike_rig(
        "run",
        "--config",
        "graph_view.yaml",
        "--out",
        str(tmp_path / "session"),
        "--param",
        f"driver.rig={tmp_path / 'rig.yaml'}",
        "--param",
        "driver.bicycle=bicycles/browser.yaml",
        "--param",
        "driver.time_scale=25",
        "--param",
        "driver.exit_when_done=true",
        "--param",
        "driver.seed=4",
        "--param",
        f"foxglove_bridge.port={port}",
    )
    served = {v.name for v in VIEW_TOPICS} - {DIAGNOSTICS.name}
    t0 = time.monotonic()
    with RosProcess("run", cmd, ros_env, tmp_path) as run:
        with foxglove_client(f"ws://127.0.0.1:{port}", timeout=90) as client:
            client.read_until(lambda: served <= set(client.by_topic()), 60, "advertise of the rig's topics")
            client.subscribe(served)
            client.read_until(lambda: client.closed, 180, "the end of the run (the bridge closing)")
        code = run.proc.wait(timeout=60)
    wall = time.monotonic() - t0
    assert code == 0, run.describe()
    bag = _bag_payloads(tmp_path / "session" / "bag")
    got = {t: [r.payload for r in v] for t, v in client.received.items()}

    gyro = got.get(GYRO.name, [])
    assert gyro, f"no gyro batch reached the client ({wall:.1f} s)"
    # gyro is live only (no kept history) and the driver does not wait for the client: it gets
    # every batch from the one it subscribed in to the last, and so whole every trial that
    # started after that (one at least: the client subscribes long before the last trial)
    start = bag[GYRO.name].index(gyro[0])
    assert bag[GYRO.name][start:] == gyro, "the gyro batches are not the bag's from the first received on, in order"
    store = rig_typestore()
    decoded = [store.deserialize_cdr(p, GYRO.type) for p in gyro]
    whole = [d.trial_id for d in decoded if d.first_index == 0]
    assert whole, f"the client subscribed during the last trial ({decoded[0].trial_id}): no trial to check whole"
    for trial in whole:
        assert sum(d.rates.size for d in decoded if d.trial_id == trial) == 15_000, f"trial {trial} is incomplete"

    for topic in (TRIAL_EVENTS.name, PERIODS.name):
        assert got[topic] == bag[topic], f"{topic}: {len(got[topic])} received, {len(bag[topic])} recorded"
    for topic in (PARAMETERS.name, MATRICES.name, EIGEN_SWEEP.name):
        # latched (KEEP_LAST 1): a reader may skip a set replaced before it was delivered (the
        # recorder and the bridge each skip different ones under load), never the latest
        assert got[topic] and got[topic][-1] == bag[topic][-1], f"{topic}: the latest is not the bag's latest"
    # one schema source: the bag's MCAP channels carry the schemas (name, encoding, text) advertised live
    advertised = client.by_topic()
    for mcap_file in sorted((tmp_path / "session" / "bag").glob("*.mcap")):
        with mcap_file.open("rb") as f:
            summary = make_reader(f).get_summary()
        assert summary is not None
        for channel in summary.channels.values():
            schema = summary.schemas[channel.schema_id]
            live = advertised[channel.topic]
            recorded = (channel.message_encoding, schema.name, schema.encoding, schema.data.decode())
            assert recorded == (live["encoding"], live["schemaName"], live["schemaEncoding"], live["schema"]), (
                channel.topic
            )
    params = store.deserialize_cdr(got[PARAMETERS.name][-1], PARAMETERS.type)
    assert params.complete and len(params.names) == len(params.values) >= 25
    print(
        f"bike-rig run with the view, 13 trials at 25x: {wall:.1f} s wall; {len(gyro)} of "
        f"{len(bag[GYRO.name])} gyro batches live, {len(whole)} trials whole"
    )


def test_bike_rig_view_prints_where_to_connect_and_serves(ros_env: dict[str, str], tmp_path: Path) -> None:
    port = free_port()
    cmd = _bike_rig("view", "--port", str(port), "--domain-id", ros_env["ROS_DOMAIN_ID"])
    env = {k: v for k, v in ros_env.items() if k != "ROS_DOMAIN_ID"}
    with RosProcess("view", cmd, env, tmp_path) as view:
        line = view.expect("serving", 60)
        assert line == f"ROS_DOMAIN_ID={ros_env['ROS_DOMAIN_ID']} to Foxglove on ws://127.0.0.1:{port}", line
        for offered in (SUBPROTOCOLS, [LEGACY_SUBPROTOCOL]):  # both names: the Foxglove app's, and Lichtblick's
            with foxglove_client(f"ws://127.0.0.1:{port}", subprotocols=offered) as client:
                client.read_until(lambda: GYRO.name in client.by_topic(), 30, "advertise")
                assert client.server_info is not None and client.server_info["name"] == "bike_rig"
        official = official_client()
        if official is not None:  # the official client (@foxglove/ws-protocol), offering foxglove.websocket.v1
            out = subprocess.run(
                [*official, f"ws://127.0.0.1:{port}", "0"], capture_output=True, text=True, timeout=60, check=False
            )
            events = [json.loads(line) for line in out.stdout.splitlines()]
            assert out.returncode == 0, (out.stdout, out.stderr)
            assert events[0] == {"event": "open", "protocol": LEGACY_SUBPROTOCOL}, events
            assert {"event": "serverInfo", "name": "bike_rig"} in events
            advertised = {t for e in events if e["event"] == "advertise" for t in e["topics"]}
            assert {v.name for v in VIEW_TOPICS} - {DIAGNOSTICS.name} <= advertised, advertised
        # nothing runs on this domain: the view says so, and how to point it at a session
        hint = view.expect("no", 60)
        assert hint.startswith(f"bike_rig graph found on ROS_DOMAIN_ID={ros_env['ROS_DOMAIN_ID']}: "), hint
        assert view.stop() == 0, view.describe()
    text = "\n".join(_all_lines(view))
    assert "  layout: Layouts > Import from file > " in text and "\nCtrl-C stops\n" in text, text
    assert "config/foxglove/bike_rig_layout.json" in text, text
    assert "\n  bike-rig run and bike-rig session print their graph's ROS_DOMAIN_ID; point the view at it: " in text
