"""A Foxglove WebSocket protocol client for tests (``websockets``' synchronous client).

Speaks the protocol as the Foxglove app does: offers the subprotocols ``foxglove.sdk.v1`` and
``foxglove.websocket.v1``, reads ``serverInfo`` and ``advertise`` (JSON text frames), sends
``subscribe`` and decodes the binary message-data frames: opcode ``0x01``, subscription id
(u32, little-endian), log time (u64, ns), then the payload (here: CDR).
"""

from __future__ import annotations

import contextlib
import json
import struct
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Subprotocol

SUBPROTOCOLS = (Subprotocol("foxglove.sdk.v1"), Subprotocol("foxglove.websocket.v1"))
MESSAGE_DATA = 0x01
_HEADER = struct.Struct("<BIQ")


@dataclass
class Received:
    """One message-data frame: its channel's topic, log time (ns) and payload."""

    topic: str
    log_time: int
    payload: bytes


@dataclass
class FoxgloveClient:
    """A connection: what the server said, and every message received per topic."""

    url: str
    ws: ClientConnection
    server_info: dict[str, Any] | None = None
    channels: dict[int, dict[str, Any]] = field(default_factory=dict)
    subscriptions: dict[int, int] = field(default_factory=dict)
    received: dict[str, list[Received]] = field(default_factory=dict)
    others: list[dict[str, Any]] = field(default_factory=list)
    closed: bool = False

    def by_topic(self) -> dict[str, dict[str, Any]]:
        """The advertised channels by topic."""
        return {c["topic"]: c for c in self.channels.values()}

    def _take(self, frame: str | bytes) -> None:
        if isinstance(frame, bytes):
            op, sub_id, log_time = _HEADER.unpack_from(frame)
            assert op == MESSAGE_DATA, f"unexpected binary opcode {op:#x}"
            topic = self.channels[self.subscriptions[sub_id]]["topic"]
            self.received.setdefault(topic, []).append(Received(topic, log_time, frame[_HEADER.size :]))
            return
        msg = json.loads(frame)
        if msg["op"] == "serverInfo":
            self.server_info = msg
        elif msg["op"] == "advertise":
            self.channels.update({c["id"]: c for c in msg["channels"]})
        elif msg["op"] == "unadvertise":
            for cid in msg["channelIds"]:
                self.channels.pop(cid, None)
        else:
            self.others.append(msg)

    def read_until(self, condition: Callable[[], bool], timeout: float, what: str) -> None:
        """Take frames until ``condition()``; fail after ``timeout`` s or when the server closes first.

        A closed connection sets :attr:`closed` (a condition may wait for it).
        """
        deadline = time.monotonic() + timeout
        while not condition():
            remaining = deadline - time.monotonic()
            got = {t: len(v) for t, v in self.received.items()}
            if remaining <= 0:
                raise AssertionError(f"{self.url}: no {what} within {timeout} s (received {got})")
            if self.closed:
                raise AssertionError(f"{self.url}: closed by the server before {what} (received {got})")
            try:
                frame = self.ws.recv(timeout=min(remaining, 0.2))
            except TimeoutError:
                continue
            except ConnectionClosed:
                self.closed = True
                continue
            self._take(frame)

    def drain(self, seconds: float) -> None:
        """Take whatever arrives for ``seconds``."""
        deadline = time.monotonic() + seconds
        while (remaining := deadline - time.monotonic()) > 0:
            try:
                self._take(self.ws.recv(timeout=remaining))
            except TimeoutError:
                return

    def subscribe(self, topics: Iterable[str]) -> None:
        """Subscribe to the advertised channels of ``topics`` (one subscription id each)."""
        by_topic = self.by_topic()
        subs = []
        for topic in topics:
            sub_id = len(self.subscriptions) + 1
            self.subscriptions[sub_id] = by_topic[topic]["id"]
            subs.append({"id": sub_id, "channelId": by_topic[topic]["id"]})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))


@contextlib.contextmanager
def foxglove_client(url: str, timeout: float = 30.0) -> Iterator[FoxgloveClient]:
    """A connected client, closed (with the closing handshake) on exit.

    Retries until the server listens, at most ``timeout`` s.
    """
    deadline = time.monotonic() + timeout
    while True:
        try:
            ws = connect(url, subprotocols=list(SUBPROTOCOLS), max_size=None, open_timeout=5)
            break
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)
    with ws:
        yield FoxgloveClient(url, ws)
