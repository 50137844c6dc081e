"""A relay in front of the Foxglove SDK's server that serves clients of either protocol name.

The SDK's WebSocket server (``foxglove-sdk`` 0.30) accepts only the subprotocol
``foxglove.sdk.v1``; the official ``@foxglove/ws-protocol`` client and the apps built on it
(Lichtblick, older Foxglove releases) offer only ``foxglove.websocket.v1``, the same protocol
under its first name. The relay listens on the view's address, accepts either name
(``foxglove.sdk.v1`` when a client offers both), opens one connection per client to the SDK's
server on loopback, and forwards every message both ways unchanged (text as text, binary as
binary, in order; a slow client slows its own connection only). When either side closes, the
other is closed with the same code.

It runs on an asyncio loop in a thread of its own (``websockets``' asyncio server and client).
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from typing import Any

from websockets.asyncio.client import ClientConnection, connect
from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed, InvalidHandshake
from websockets.typing import Subprotocol

from ...core.errors import BikeRigError

__all__ = ["LEGACY_SUBPROTOCOL", "SDK_SUBPROTOCOL", "SUBPROTOCOLS", "FoxgloveRelay", "RelayError"]

#: The subprotocol name the SDK's server accepts.
SDK_SUBPROTOCOL = Subprotocol("foxglove.sdk.v1")
#: The protocol's first name, the only one ``@foxglove/ws-protocol`` clients offer.
LEGACY_SUBPROTOCOL = Subprotocol("foxglove.websocket.v1")
#: What the relay accepts, preferred first.
SUBPROTOCOLS = (SDK_SUBPROTOCOL, LEGACY_SUBPROTOCOL)
#: Close codes that a side reports but must not send (no status, abnormal, TLS failure).
_UNSENDABLE = {1005, 1006, 1015}
#: Seconds to wait for the relay to listen, or to stop.
_START_S = 30.0


class RelayError(BikeRigError):
    """The relay cannot listen on the address (the port is taken, the address is not this computer's).

    Attributes:
        why: The operating system's reason.
    """

    def __init__(self, host: str, port: int, why: str) -> None:
        """Say where and why."""
        super().__init__(f"cannot listen on {host}:{port} ({why})")
        self.why = why


class FoxgloveRelay:
    """Listen on ``host:port`` and relay each client to the SDK's server on ``127.0.0.1:upstream_port``.

    Args:
        host: Address to listen on.
        port: Port to listen on (0: a free one; :attr:`port` is the one taken).
        upstream_port: The SDK server's port on loopback.

    Raises:
        RelayError: The address cannot be listened on.
    """

    def __init__(self, host: str, port: int, upstream_port: int) -> None:
        """Start the relay's thread and listen."""
        self.upstream = f"ws://127.0.0.1:{upstream_port}"
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, name="foxglove-relay", daemon=True)
        self._thread.start()
        try:
            self._server: Server = self._call(self._listen(host, port))
        except (OSError, TimeoutError) as exc:
            self._halt()
            raise RelayError(host, port, str(exc) or type(exc).__name__) from None
        self.port = int(self._server.sockets[0].getsockname()[1])

    def _call(self, coro: Any) -> Any:
        return asyncio.run_coroutine_threadsafe(coro, self._loop).result(timeout=_START_S)

    async def _listen(self, host: str, port: int) -> Server:
        return await serve(self._relay, host, port, subprotocols=list(SUBPROTOCOLS), compression=None, max_size=None)

    async def _relay(self, client: ServerConnection) -> None:
        """One client: connect to the SDK's server and forward both ways until one side closes."""
        try:
            upstream = await connect(
                self.upstream,
                subprotocols=[SDK_SUBPROTOCOL],
                compression=None,
                max_size=None,
                ping_interval=None,
                open_timeout=10,
            )
        except (OSError, TimeoutError, InvalidHandshake) as exc:
            await client.close(1011, f"the live view's server does not answer ({exc})"[:120])
            return
        async with upstream:
            await _forward_both_ways(client, upstream)

    def stop(self) -> None:
        """Close every client connection (code 1001, going away) and stop listening (idempotent)."""
        if not self._thread.is_alive():
            return
        with contextlib.suppress(Exception):
            self._call(self._close())
        self._halt()

    async def _close(self) -> None:
        self._server.close(close_connections=True)
        await self._server.wait_closed()

    def _halt(self) -> None:
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(timeout=_START_S)
        if not self._thread.is_alive():
            self._loop.close()


async def _pump(source: ServerConnection | ClientConnection, sink: ServerConnection | ClientConnection) -> None:
    """Send each message of ``source`` to ``sink`` until ``source`` closes, then close ``sink`` alike."""
    with contextlib.suppress(ConnectionClosed):
        async for message in source:
            await sink.send(message)
    code = source.close_code
    reason = source.close_reason or ""
    await sink.close(1001 if code is None or code in _UNSENDABLE else code, reason)


async def _forward_both_ways(client: ServerConnection, upstream: ClientConnection) -> None:
    tasks = [asyncio.create_task(_pump(client, upstream)), asyncio.create_task(_pump(upstream, client))]
    done, pending = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    for task in pending:
        task.cancel()
    await asyncio.gather(*pending, return_exceptions=True)
    for task in done:
        with contextlib.suppress(ConnectionClosed):
            task.result()
