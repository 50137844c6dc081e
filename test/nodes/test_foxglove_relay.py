"""The relay in front of the Foxglove SDK's server, with real clients over the real protocol.

An SDK server in this process (``foxglove.start_server`` on a free loopback port, one channel
with a ``ros2msg`` schema and ``cdr`` encoding, as the bridge serves) behind a
:class:`~bike_rig.ros.nodes.foxglove_relay.FoxgloveRelay`. Clients offering either protocol name
(``foxglove.sdk.v1``, ``foxglove.websocket.v1``) get the server's ``serverInfo`` and
``advertise`` and, once subscribed, every message logged, byte for byte and in order; a client
offering neither is refused with HTTP 400; stopping the relay closes its clients. The official
client (``@foxglove/ws-protocol`` under Node, installed by ``tools/setup_node.sh``) does the
same with the name it offers by default.
"""

from __future__ import annotations

import json
import subprocess
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from bike_rig.ros.nodes.foxglove_relay import LEGACY_SUBPROTOCOL, SDK_SUBPROTOCOL, FoxgloveRelay, RelayError
from test.support.foxglove_client import foxglove_client, official_client

foxglove = pytest.importorskip("foxglove")

TOPIC = "/bike_rig/test"


class _Server:
    """An SDK server with one channel; :attr:`subscribed` is set once a client subscribes to it.

    The SDK registers a subscription before it calls ``on_subscribe``: what is logged after
    the event reaches the client.
    """

    def __init__(self) -> None:
        from foxglove.websocket import ServerListener

        self.context = foxglove.Context()
        schema = foxglove.Schema(name="std_msgs/msg/String", encoding="ros2msg", data=b"string data\n")
        self.channel = foxglove.Channel(TOPIC, schema=schema, message_encoding="cdr", context=self.context)
        self.subscribed = threading.Event()
        server = self

        class Listener(ServerListener):
            def on_subscribe(self, client: Any, channel: Any) -> None:
                server.subscribed.set()

        self.server = foxglove.start_server(
            name="relay-test", host="127.0.0.1", port=0, context=self.context, server_listener=Listener()
        )

    def log(self, n: int) -> list[bytes]:
        payloads = [i.to_bytes(4, "little") + bytes(range(i % 200)) for i in range(n)]
        for data in payloads:
            self.channel.log(data)
        return payloads


@pytest.fixture
def served() -> Iterator[tuple[_Server, FoxgloveRelay]]:
    server = _Server()
    relay = FoxgloveRelay("127.0.0.1", 0, server.server.port)
    try:
        yield server, relay
    finally:
        relay.stop()
        server.server.stop()


@pytest.mark.parametrize("offered", [[SDK_SUBPROTOCOL], [LEGACY_SUBPROTOCOL], [LEGACY_SUBPROTOCOL, SDK_SUBPROTOCOL]])
def test_a_client_of_either_name_gets_every_message(served: tuple[_Server, FoxgloveRelay], offered: list[str]) -> None:
    server, relay = served
    with foxglove_client(f"ws://127.0.0.1:{relay.port}", subprotocols=offered) as client:
        assert client.ws.subprotocol == (SDK_SUBPROTOCOL if SDK_SUBPROTOCOL in offered else LEGACY_SUBPROTOCOL)
        client.read_until(lambda: TOPIC in client.by_topic(), 30, "advertise")
        assert client.server_info is not None and client.server_info["name"] == "relay-test"
        channel = client.by_topic()[TOPIC]
        assert (channel["encoding"], channel["schemaName"], channel["schema"]) == (
            "cdr",
            "std_msgs/msg/String",
            "string data\n",
        )
        client.subscribe([TOPIC])
        assert server.subscribed.wait(30), "the server saw no subscription through the relay"
        sent = server.log(500)
        client.read_until(lambda: len(client.received.get(TOPIC, [])) >= len(sent), 30, "500 messages")
        assert [r.payload for r in client.received[TOPIC]] == sent


def test_a_client_offering_neither_name_is_refused(served: tuple[_Server, FoxgloveRelay]) -> None:
    _, relay = served
    with pytest.raises(InvalidStatus) as info:
        connect(f"ws://127.0.0.1:{relay.port}", subprotocols=["chat"], open_timeout=10)  # type: ignore[list-item]
    assert info.value.response.status_code == 400


def test_stopping_the_relay_closes_its_clients(served: tuple[_Server, FoxgloveRelay]) -> None:
    _, relay = served
    with foxglove_client(f"ws://127.0.0.1:{relay.port}", subprotocols=[LEGACY_SUBPROTOCOL]) as client:
        client.read_until(lambda: TOPIC in client.by_topic(), 30, "advertise")
        relay.stop()
        client.read_until(lambda: client.closed, 30, "the close")
    assert client.ws.close_code == 1001


def test_a_taken_port_is_one_relay_error(served: tuple[_Server, FoxgloveRelay]) -> None:
    server, relay = served
    with pytest.raises(RelayError, match=rf"^cannot listen on 127\.0\.0\.1:{relay.port} \(") as info:
        FoxgloveRelay("127.0.0.1", relay.port, server.server.port)
    assert "\n" not in str(info.value)


def _official_client() -> list[str]:
    command = official_client()
    if command is None:
        pytest.skip("the official client is not installed: run tools/setup_node.sh (needs node and npm)")
    return command


@pytest.mark.parametrize("subprotocol", [None, SDK_SUBPROTOCOL])
def test_the_official_client_gets_every_message(served: tuple[_Server, FoxgloveRelay], subprotocol: str | None) -> None:
    server, relay = served
    cmd = [*_official_client(), f"ws://127.0.0.1:{relay.port}", "100", *([subprotocol] if subprotocol else [])]
    with subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as probe:
        try:
            deadline = time.monotonic() + 60
            while not server.subscribed.wait(0.1):
                assert probe.poll() is None and time.monotonic() < deadline, probe.communicate(timeout=10)
            sent = server.log(100)
            out, err = probe.communicate(timeout=60)
        finally:
            probe.kill()
    events = [json.loads(line) for line in out.splitlines()]
    assert probe.returncode == 0, (out, err)
    assert events[0] == {"event": "open", "protocol": subprotocol or LEGACY_SUBPROTOCOL}
    assert {"event": "serverInfo", "name": "relay-test"} in events
    assert {"event": "advertise", "topics": [TOPIC]} in events
    got = [bytes.fromhex(e["hex"]) for e in events if e["event"] == "message"]
    assert got == sent and events[-1] == {"event": "done"}
