"""What the relay in front of the Foxglove SDK's server costs: latency and throughput, direct vs relayed.

An SDK server in this process with one channel (``cdr``), a Python protocol client
(``websockets``) connected either to it directly (``foxglove.sdk.v1``) or through
:class:`bike_rig.ros.nodes.foxglove_relay.FoxgloveRelay` (``foxglove.websocket.v1``). Printed:

* latency: median and 95th percentile, ms, from ``channel.log`` to the client's receipt of one
  408-byte message (a 50-sample gyro batch's size), over 300 messages sent one at a time;
* throughput: messages per second when 20,000 of them are logged at once (the server's backlog
  holds them all) until the last arrives; and the ratio relayed / direct.
"""

from __future__ import annotations

import json
import statistics
import threading
import time
from typing import Any

import foxglove
from foxglove.websocket import ServerListener
from websockets.sync.client import connect

from bike_rig.ros.nodes.foxglove_relay import LEGACY_SUBPROTOCOL, SDK_SUBPROTOCOL, FoxgloveRelay

PAYLOAD = bytes(408)
LATENCY_N = 300
BURST_N = 20_000


def _served() -> tuple[Any, Any, Any, threading.Event]:
    """The server, its channel, its context (kept alive: the SDK drops a collected context's channels)."""
    context = foxglove.Context()
    schema = foxglove.Schema(name="std_msgs/msg/String", encoding="ros2msg", data=b"string data\n")
    channel = foxglove.Channel("/bench", schema=schema, message_encoding="cdr", context=context)
    subscribed = threading.Event()

    class Listener(ServerListener):
        def on_subscribe(self, client: Any, ch: Any) -> None:
            subscribed.set()

    server = foxglove.start_server(
        host="127.0.0.1", port=0, context=context, server_listener=Listener(), message_backlog_size=BURST_N + 100
    )
    return server, channel, context, subscribed


def measure(port: int, subprotocol: str, channel: Any, subscribed: threading.Event) -> tuple[list[float], float]:
    """(latencies s, burst messages per s) for a client on ``port`` offering ``subprotocol``."""
    subscribed.clear()
    with connect(f"ws://127.0.0.1:{port}", subprotocols=[subprotocol], max_size=None) as ws:  # type: ignore[list-item]
        while True:
            msg = json.loads(ws.recv(timeout=10))
            if msg["op"] == "advertise":
                break
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": msg["channels"][0]["id"]}]}))
        assert subscribed.wait(10)
        latencies = []
        for _ in range(LATENCY_N):
            t0 = time.perf_counter()
            channel.log(PAYLOAD)
            while not isinstance(ws.recv(timeout=10), bytes):
                pass
            latencies.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for _ in range(BURST_N):
            channel.log(PAYLOAD)
        got = 0
        while got < BURST_N:
            if isinstance(ws.recv(timeout=30), bytes):
                got += 1
        return latencies, BURST_N / (time.perf_counter() - t0)


def main() -> None:
    server, channel, _context, subscribed = _served()
    relay = FoxgloveRelay("127.0.0.1", 0, server.port)
    try:
        rows = {
            "direct (foxglove.sdk.v1)": measure(server.port, SDK_SUBPROTOCOL, channel, subscribed),
            "relayed (foxglove.websocket.v1)": measure(relay.port, LEGACY_SUBPROTOCOL, channel, subscribed),
        }
    finally:
        relay.stop()
        server.stop()
    print(f"{'client':<32} {'latency median ms':>17} {'p95 ms':>7} {'burst msg/s':>12}")
    for name, (lat, rate) in rows.items():
        p95 = statistics.quantiles(lat, n=20)[-1]
        print(f"{name:<32} {1e3 * statistics.median(lat):>17.3f} {1e3 * p95:>7.3f} {rate:>12.0f}")
    (_, direct), (_, relayed) = rows.values()
    print(f"relayed / direct throughput: {relayed / direct:.2f}")


if __name__ == "__main__":
    main()
