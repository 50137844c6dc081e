"""The Foxglove bridge node: the live graph served to the Foxglove app over its WebSocket protocol.

The server is the ``foxglove-sdk`` wheel's (:func:`foxglove.start_server`; imported only by this
node and ``bike-rig view``), on a free loopback port; clients connect to the relay of
:mod:`bike_rig.ros.nodes.foxglove_relay` on ``host:port``, which accepts both names of the protocol
(``foxglove.sdk.v1``, and ``foxglove.websocket.v1`` of the ``@foxglove/ws-protocol`` client and
Lichtblick) and forwards each client's messages to and from the SDK's server unchanged.

Each topic of :data:`bike_rig.ros.liveview.VIEW_TOPICS` is subscribed
raw (``raw=True``: the serialized CDR, with its encapsulation header, as DDS delivers it) and
forwarded unchanged to a Foxglove channel of the same name, message encoding ``cdr``, schema
``ros2msg`` (the type's definition text, as the recorder writes it into MCAP): Foxglove decodes
bike_rig's own messages from that text. Log time: when the bridge takes the message.

A topic whose message type is not importable here (``diagnostic_msgs`` when its wheel is not
installed) is left out, with one log line. A Foxglove client that subscribes to a channel gets
the messages the bridge keeps for it first (:attr:`bike_rig.ros.liveview.ViewTopic.replay_depth`:
the transient-local topics' history), then the live ones, none twice: a late client sees the
session so far.

Parameters (``config/foxglove_bridge.yaml``):

* ``port`` (integer): the WebSocket port, 8765 by default (Foxglove's); 0 picks a free one.
* ``host`` (string): the address to listen on, ``127.0.0.1`` by default (this computer only;
  ``0.0.0.0`` serves every interface).

Run: ``bike-rig view [--port N] [--domain-id N]``, or ``python -m bike_rig.ros.nodes.foxglove_bridge
--ros-args -p port:=8765``, or as a node of a graph (``config/graph_view.yaml``).
"""

from __future__ import annotations

import collections
import importlib
import sys
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ...config.settings import ParamSpec
from ...core.errors import BikeRigError
from ..liveview import DEFAULT_PORT, DIAGNOSTICS, VIEW_TOPICS, ViewTopic, schema_text
from .foxglove_relay import FoxgloveRelay, RelayError

if TYPE_CHECKING:
    from rclpy.node import Node

__all__ = ["NODE_NAME", "PARAMETERS", "BridgeError", "FoxgloveBridge", "main"]

NODE_NAME = "foxglove_bridge"
#: Live messages the server may queue per client beyond a replay (the SDK's default backlog).
LIVE_BACKLOG = 1024

#: The bridge's parameters (``config/foxglove_bridge.yaml``).
PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("port", DEFAULT_PORT, "WebSocket port of the Foxglove server (0: a free one)", (0, 65535)),
    ParamSpec("host", "127.0.0.1", "address the server listens on (0.0.0.0: every interface)"),
)


class BridgeError(BikeRigError):
    """The Foxglove server cannot start (the port is taken, the address is not this computer's)."""


def message_class(msgtype: str) -> Any | None:
    """The rclpy message class of ``pkg/msg/Name``, or None when its package is not installed."""
    package, _, name = msgtype.split("/")
    try:
        return getattr(importlib.import_module(f"{package}.msg"), name)
    except (ImportError, AttributeError):
        return None


def backlog_size() -> int:
    """Messages the server may queue per client: every kept message (a late client's replay) and a live margin.

    The SDK's default, 1024, is less than a full replay (the trial events, periods, fit details
    and readings keep up to 2000 each): a client that reads slower than the server sends (across
    a network) would lose the oldest. (A client on this computer keeps up: the 2000 kept trial
    events of ``test/nodes/test_foxglove_bridge.py`` arrive in full with the default too.)
    """
    return sum(v.replay_depth for v in VIEW_TOPICS) + LIVE_BACKLOG


class _Forwarder:
    """One topic: its Foxglove channel, the clients subscribed to it, the messages kept for later ones.

    Every message goes to each subscribed client by its id (the SDK logs to one client by its
    id, its sink id), under one lock with the subscriptions: a client that subscribes gets the
    kept messages, then each later one, none twice and, of the kept topics, none missed. A gyro
    batch that arrives while a client's subscription is being set up (milliseconds) does not
    reach that client.
    """

    def __init__(self, view: ViewTopic, channel: Any, lock: threading.Lock) -> None:
        self.view = view
        self.channel = channel
        self.kept: collections.deque[tuple[bytes, int]] = collections.deque(maxlen=max(view.replay_depth, 1))
        self.clients: set[int] = set()
        self._lock = lock

    def forward(self, data: bytes) -> None:
        """Send one serialized message to every subscribed client (and keep it)."""
        now = time.time_ns()
        with self._lock:
            if self.view.replay_depth:
                self.kept.append((data, now))
            for client in self.clients:
                self.channel.log(data, log_time=now, sink_id=client)

    def subscribe(self, client: int) -> int:
        """A client subscribed: send it the kept messages, then the live ones; returns how many were kept."""
        with self._lock:
            kept = list(self.kept) if self.view.replay_depth else []
            for data, stamp in kept:
                self.channel.log(data, log_time=stamp, sink_id=client)
            self.clients.add(client)
        return len(kept)

    def unsubscribe(self, client: int) -> None:
        """A client unsubscribed or left."""
        with self._lock:
            self.clients.discard(client)


def _listener(by_channel: dict[int, _Forwarder]) -> Any:
    """The server's listener: tells each channel's forwarder which clients subscribe.

    Args:
        by_channel: The forwarder of each Foxglove channel id.
    """
    from foxglove.websocket import ServerListener

    class Listener(ServerListener):  # (the protocol's other callbacks: its no-op defaults)
        def on_subscribe(self, client: Any, channel: Any) -> None:
            forwarder = by_channel.get(channel.id)
            if forwarder is not None:
                forwarder.subscribe(client.id)

        def on_unsubscribe(self, client: Any, channel: Any) -> None:
            forwarder = by_channel.get(channel.id)
            if forwarder is not None:
                forwarder.unsubscribe(client.id)

    return Listener()


class FoxgloveBridge:
    """The ROS adapter: raw subscriptions in, Foxglove channels out (see the module docstring).

    ``self.node`` is the rclpy node (named ``foxglove_bridge``); ``self.url`` the server's
    ``ws://`` address; ``self.skipped`` the topics left out and why.
    """

    def __init__(self) -> None:
        """Declare the parameters, create the channels, start the server, subscribe.

        Raises:
            NodeParameterError: A parameter is invalid.
            BridgeError: The server cannot listen on the host and port.
        """
        import foxglove
        from rclpy.node import Node

        from ..qos import profile
        from .settings import declare_parameters

        self.node: Node = Node(NODE_NAME)
        values = declare_parameters(self.node, PARAMETERS)
        self.context = foxglove.Context()
        self._lock = threading.Lock()
        self.forwarders: dict[str, _Forwarder] = {}
        self.skipped: dict[str, str] = {}
        classes: dict[str, Any] = {}
        for view in VIEW_TOPICS:
            cls = message_class(view.type)
            if cls is None:
                self.skipped[view.name] = f"{view.type} is not installed"
                continue
            schema = foxglove.Schema(name=view.type, encoding="ros2msg", data=schema_text(view.type).encode())
            channel = foxglove.Channel(view.name, schema=schema, message_encoding="cdr", context=self.context)
            self.forwarders[view.name] = _Forwarder(view, channel, self._lock)
            classes[view.name] = cls
        listener = _listener({f.channel.id(): f for f in self.forwarders.values()})
        host, port = values["host"], values["port"]
        try:
            self.server = foxglove.start_server(
                name="bike_rig",
                host="127.0.0.1",
                port=0,
                context=self.context,
                server_listener=listener,
                message_backlog_size=backlog_size(),
            )
        except Exception as exc:  # the SDK raises RuntimeError or its own error types
            raise BridgeError(f"cannot start the live view's server on 127.0.0.1 ({exc})") from None
        try:
            self.relay = FoxgloveRelay(host, port, self.server.port)
        except RelayError as exc:
            self.server.stop()
            raise BridgeError(f"cannot serve the live view on {host}:{port} ({exc.why})") from None
        self.url = f"ws://{host}:{self.relay.port}"
        for name, forwarder in self.forwarders.items():
            self.node.create_subscription(
                classes[name], name, self._callback(forwarder), profile(forwarder.view.qos), raw=True
            )
        for name, why in self.skipped.items():
            self.node.get_logger().warning(f"{name} not served: {why}")
        self.node.get_logger().info(f"serving {len(self.forwarders)} topics to Foxglove on {self.url}")

    def _callback(self, forwarder: _Forwarder) -> Any:
        def on_message(data: bytes, _info: Any) -> None:
            try:  # a callback must never raise: log and keep serving
                forwarder.forward(bytes(data))
            except Exception as exc:
                self.node.get_logger().error(f"{forwarder.view.name}: not forwarded: {exc!r}")

        return on_message

    def rig_publishers(self) -> tuple[set[str], set[str]]:
        """The rig's served topics that have a publisher now (``/diagnostics`` aside), and those publishers' nodes."""
        topics: set[str] = set()
        nodes: set[str] = set()
        for name in self.forwarders:
            if name == DIAGNOSTICS.name:
                continue
            found = self.node.get_publishers_info_by_topic(name)
            if found:
                topics.add(name)
                nodes.update(info.node_name for info in found)
        return topics, nodes

    def close(self) -> None:
        """Stop the relay and the server (clients see the connection close)."""
        self.relay.stop()
        self.server.stop()


def main(args: list[str] | None = None, on_started: Callable[[FoxgloveBridge], None] | None = None) -> int:
    """Run the bridge node (``--ros-args -p port:=N -p host:=ADDR`` work).

    Args:
        args: The command line (default: ``sys.argv``).
        on_started: Called once the server listens (``bike-rig view`` prints the address).
    """
    from .runner import run_node

    bridge: list[FoxgloveBridge] = []

    def build() -> Node:
        bridge.append(FoxgloveBridge())
        if on_started is not None:
            on_started(bridge[0])
        return bridge[0].node

    status = run_node(build, args, name=NODE_NAME)
    if bridge:
        bridge[0].close()
    return status


if __name__ == "__main__":
    sys.exit(main())
