"""Both names of Foxglove's WebSocket subprotocol on one port: a relay in front of the SDK.

The foxglove-sdk server (0.30.3, pinned) accepts a client only if it offers the subprotocol
``foxglove.sdk.v1`` and answers HTTP 400 otherwise: its handshake compares the offered names
with one constant and has no option for another (``rust/foxglove/src/websocket/handshake.rs``
in foxglove/foxglove-sdk; the 0.30.3 wheel holds no other name). Older Foxglove builds and
older Lichtblick releases offer only ``foxglove.websocket.v1``, the same protocol under its
first name (foxglove/ws-protocol, docs/spec.md). :class:`Relay` listens where users connect,
accepts either name (``foxglove.sdk.v1`` when a client offers both; neither: HTTP 400, as the
SDK does), and for each client opens one connection to the SDK server on a private localhost
port and copies every frame both ways unchanged (text as text, binary as binary). When
either side closes, the other is closed too.

It runs its own asyncio loop in a daemon thread, so the embedded runner and the live node
keep their own loops; it relays only while a client is connected.
"""

from __future__ import annotations

import asyncio
import threading
from typing import cast

import websockets
from websockets.asyncio.client import ClientConnection, connect
from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.typing import Subprotocol

SDK_SUBPROTOCOL = 'foxglove.sdk.v1'
LEGACY_SUBPROTOCOL = 'foxglove.websocket.v1'
#: What the relay accepts, in order of preference.
SUBPROTOCOLS = (Subprotocol(SDK_SUBPROTOCOL), Subprotocol(LEGACY_SUBPROTOCOL))
#: Wall seconds to wait for the relay to start or stop.
TIMEOUT = 10.0
#: Wall seconds a connection's closing handshake may take before it is dropped: a client that
#: stopped reading (a frozen page) must not hold a stopping live view past the launcher's 6 s
#: between SIGINT and SIGTERM (websockets waits 10 s by default, for each side of a relay).
CLOSE_TIMEOUT = 1.0


class Relay:
    """Accepts Foxglove clients on ``host:port`` and relays each to the SDK server.

    Args:
        host: interface to listen on.
        port: TCP port (0: any free one; :attr:`port` tells which).
        upstream_port: the SDK server's port on 127.0.0.1.

    Raises:
        RuntimeError: it cannot listen there (the port is taken, ...).
    """

    def __init__(self, host: str, port: int, upstream_port: int) -> None:
        self.upstream = f'ws://127.0.0.1:{upstream_port}'
        self.port = 0
        self._loop = asyncio.new_event_loop()
        self._server: Server | None = None
        self._error: BaseException | None = None
        self._clients: set[asyncio.Task] = set()  # the handlers of the connected clients
        self._ready = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(host, port),
                                        name='foxglove-relay', daemon=True)
        self._thread.start()
        if not self._ready.wait(TIMEOUT) or self._error is not None:
            self.stop()
            raise RuntimeError(str(self._error or 'the relay did not start'))

    def _run(self, host: str, port: int) -> None:
        asyncio.set_event_loop(self._loop)
        async def start() -> Server:
            return await serve(self._handle, host, port, subprotocols=list(SUBPROTOCOLS),
                               max_size=None, compression=None, close_timeout=CLOSE_TIMEOUT)
        try:
            self._server = self._loop.run_until_complete(start())
            self.port = self._server.sockets[0].getsockname()[1]
        except Exception as error:  # noqa: BLE001 - reported to the caller, in its thread
            self._error = error
        finally:
            self._ready.set()
        if self._error is None:
            self._loop.run_forever()
        self._loop.close()

    async def _handle(self, client: ServerConnection) -> None:
        """One client: its own connection to the SDK server, frames copied both ways."""
        self._clients.add(cast(asyncio.Task[None], asyncio.current_task()))
        try:
            async with connect(self.upstream, subprotocols=[Subprotocol(SDK_SUBPROTOCOL)],
                               max_size=None, compression=None, open_timeout=TIMEOUT,
                               close_timeout=CLOSE_TIMEOUT) as sdk:
                copies = [asyncio.create_task(_copy(client, sdk)),
                          asyncio.create_task(_copy(sdk, client))]
                try:
                    await asyncio.wait(copies, return_when=asyncio.FIRST_COMPLETED)
                finally:  # one side closed, or the relay stops: a copy blocked on a client
                    for task in copies:  # that stopped reading must not outlive it
                        task.cancel()
        except (OSError, websockets.InvalidHandshake, asyncio.TimeoutError):
            await client.close(1011, 'the live view server is not available')
        finally:
            self._clients.discard(asyncio.current_task())

    def stop(self) -> None:
        """Close every connection and stop listening (safe to call twice)."""
        if not self._thread.is_alive():
            return
        if self._server is not None:
            async def close(server: Server) -> None:
                server.close(close_connections=False)  # no new clients
                for client in list(self._clients):
                    client.cancel()  # each closes its connections (CLOSE_TIMEOUT at most)
                await server.wait_closed()
            try:
                asyncio.run_coroutine_threadsafe(close(self._server), self._loop).result(TIMEOUT)
            except (TimeoutError, RuntimeError):
                pass  # stopping anyway
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(TIMEOUT)


async def _copy(source: ServerConnection | ClientConnection,
                sink: ServerConnection | ClientConnection) -> None:
    """Every frame of ``source`` to ``sink``, until either closes."""
    try:
        async for frame in source:
            await sink.send(frame)
    except websockets.ConnectionClosed:
        pass
    finally:
        await sink.close()
