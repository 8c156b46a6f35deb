"""A Foxglove WebSocket client for tests: connects to a live view, lists the advertised
channels, subscribes, and decodes what arrives with the advertised ``ros2msg`` schemas
(mcap-ros2-support's decoder, independent of the project's and of rosbags' code).

Protocol (foxglove-sdk 0.30, subprotocol ``foxglove.sdk.v1``): the server sends JSON
``serverInfo`` and ``advertise``; the client sends JSON ``subscribe``; the server then sends
binary frames: opcode 1 (message data: subscription id u32, log time u64, payload) and
opcode 2 (time: u64).
"""

from __future__ import annotations

import asyncio
import json
import struct
import time
from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import websockets
from mcap_ros2._dynamic import generate_dynamic

SUBPROTOCOL = 'foxglove.sdk.v1'
#: The protocol's first name, which older Foxglove and Lichtblick clients offer alone.
LEGACY_SUBPROTOCOL = 'foxglove.websocket.v1'


@dataclass
class Capture:
    """What a client saw."""

    server_info: dict = field(default_factory=dict)
    channels: dict[str, dict] = field(default_factory=dict)  #: topic -> advertised channel
    messages: dict[str, list[tuple[int, object]]] = field(default_factory=dict)
    times: list[int] = field(default_factory=list)  #: the server's time broadcasts
    subprotocol: str = ''  #: the one the server chose


async def _capture(url: str, topics: Iterable[str] | None, seconds: float,
                   done: Callable[[Capture], bool] | None, decode: bool,
                   subprotocols: list[str]) -> Capture:
    capture = Capture()
    async with websockets.connect(url, subprotocols=subprotocols, max_size=None) as ws:
        assert ws.subprotocol in subprotocols
        capture.subprotocol = ws.subprotocol
        decoders: dict[int, tuple[str, Callable]] = {}
        deadline = time.monotonic() + seconds
        subscribed = False
        while time.monotonic() < deadline and not (done and subscribed and done(capture)):
            try:
                frame = await asyncio.wait_for(ws.recv(), max(0.01, deadline - time.monotonic()))
            except (asyncio.TimeoutError, websockets.ConnectionClosed):
                break  # enough seen, or the server is gone (the episode ended)
            if isinstance(frame, str):
                document = json.loads(frame)
                if document['op'] == 'serverInfo':
                    capture.server_info = document
                elif document['op'] == 'advertise':
                    subscriptions = []
                    for channel in document['channels']:
                        capture.channels[channel['topic']] = channel
                        if topics is None or channel['topic'] in topics:
                            sub = len(decoders) + 1
                            decoders[sub] = (channel['topic'], generate_dynamic(
                                channel['schemaName'], channel['schema'])[channel['schemaName']])
                            subscriptions.append({'id': sub, 'channelId': channel['id']})
                    if subscriptions:
                        await ws.send(json.dumps({'op': 'subscribe',
                                                  'subscriptions': subscriptions}))
                        subscribed = True
            elif frame[0] == 1:
                sub, log_time = struct.unpack_from('<IQ', frame, 1)
                topic, decoder = decoders[sub]
                capture.messages.setdefault(topic, []).append(
                    (log_time, decoder(frame[13:]) if decode else len(frame) - 13))
            elif frame[0] == 2:
                capture.times.append(struct.unpack_from('<Q', frame, 1)[0])
    return capture


def capture(url: str, *, topics: Iterable[str] | None = None, seconds: float = 5.0,
            done: Callable[[Capture], bool] | None = None, decode: bool = True,
            subprotocols: Iterable[str] = (SUBPROTOCOL,)) -> Capture:
    """Connect to ``url`` offering ``subprotocols``, subscribe to ``topics`` (default: every
    advertised one) and decode what arrives for ``seconds`` or until ``done(capture)`` holds
    (``decode`` False: keep each payload's size instead)."""
    watching = _capture(url, None if topics is None else set(topics), seconds, done, decode,
                        list(subprotocols))
    # In a thread of its own: the caller's thread may run an event loop already (Playwright's
    # sync API does while a browser is open), and asyncio runs one loop per thread.
    with ThreadPoolExecutor(max_workers=1) as pool:
        return pool.submit(asyncio.run, watching).result()


def connect_when_up(url: str, timeout: float = 60.0, **kwargs) -> Capture:
    """:func:`capture`, retrying the connection until the server listens."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            return capture(url, **kwargs)
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)
