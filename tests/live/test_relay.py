"""Both names of the subprotocol: a real client offering only ``foxglove.websocket.v1`` (what
older Foxglove builds and Lichtblick releases offer) is refused by the foxglove-sdk server
itself and served through the live view's relay; one offering both gets ``foxglove.sdk.v1``;
one offering neither is refused with HTTP 400, as the SDK refuses it; and a client that stopped
reading does not hold the live view's stop."""

from __future__ import annotations

import asyncio
import concurrent.futures
import os
import signal
import subprocess
import sys
import threading
import time

import pytest
import websockets

from mona_controller.topics import CLOCK, POSES
from swarm_supervisor.media.live import LiveServer
from swarm_world.messages.cdr import clock_cdr, pose_array_cdr

from foxclient import LEGACY_SUBPROTOCOL, SUBPROTOCOL, Capture, capture

NS = 5_000_000_000


@pytest.fixture
def server():
    live = LiveServer(0, topics={POSES: 'geometry_msgs/msg/PoseArray',
                                 CLOCK: 'rosgraph_msgs/msg/Clock'})
    try:
        yield live
    finally:
        live.stop()


def handshake(url: str, offered: list[str]) -> str:
    """The subprotocol the server chose, or ``'HTTP <status>'`` if it refused."""
    async def connect() -> str:
        try:
            async with websockets.connect(url, subprotocols=offered) as ws:
                return ws.subprotocol
        except websockets.InvalidStatus as error:
            return f'HTTP {error.response.status_code}'
    # In a thread of its own: a test before it on this worker may have left an event loop
    # marked running in the main thread (asyncio.run() then refuses to start).
    with concurrent.futures.ThreadPoolExecutor(1) as thread:
        return thread.submit(asyncio.run, connect()).result()


def watch(server: LiveServer, offered: list[str]) -> Capture:
    """A client offering ``offered`` subscribes while the server publishes poses."""
    result: list[Capture] = []
    client = threading.Thread(target=lambda: result.append(capture(
        server.url, subprotocols=offered, seconds=20.0,
        done=lambda seen: len(seen.messages.get(POSES, ())) >= 3)))
    client.start()
    k = 0
    while client.is_alive():
        k += 1
        server.set_time(NS + k)
        server.publish(POSES, NS + k, pose_array_cdr([[1.0, 2.0, 0.5], [2.0, 1.0, -1.0]],
                                                      NS + k))
        server.publish(CLOCK, NS + k, clock_cdr(NS + k))
        client.join(0.02)
    return result[0]


def test_the_sdk_server_alone_refuses_the_older_name(server):
    """Why the relay exists (foxglove-sdk 0.30.3): its own port answers 400."""
    sdk = f'ws://127.0.0.1:{server.server.port}'
    assert handshake(sdk, [SUBPROTOCOL]) == SUBPROTOCOL
    assert handshake(sdk, [LEGACY_SUBPROTOCOL]) == 'HTTP 400'


@pytest.mark.parametrize('offered, chosen', [
    ([SUBPROTOCOL], SUBPROTOCOL),
    ([LEGACY_SUBPROTOCOL], LEGACY_SUBPROTOCOL),
    ([LEGACY_SUBPROTOCOL, SUBPROTOCOL], SUBPROTOCOL),  # current Lichtblick offers both
    (['foxglove.websocket.v2'], 'HTTP 400'),
    ([], 'HTTP 400'),
])
def test_the_live_view_negotiates_either_name(server, offered, chosen):
    assert handshake(server.url, offered) == chosen


def test_a_client_offering_only_the_older_name_sees_the_channels_and_messages(server):
    seen = watch(server, [LEGACY_SUBPROTOCOL])
    assert seen.subprotocol == LEGACY_SUBPROTOCOL
    assert seen.server_info['name'] == 'mona-swarm' and 'time' in seen.server_info['capabilities']
    assert set(seen.channels) == {POSES, CLOCK}
    poses = seen.messages[POSES]
    assert len(poses) >= 3
    log_time, msg = poses[-1]
    assert [(p.position.x, p.position.y) for p in msg.poses] == [(1.0, 2.0), (2.0, 1.0)]
    assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == log_time > NS
    assert seen.times and seen.times[-1] > NS  # the server's clock comes through too


FROZEN_CLIENT = """
import json, sys, time
from websockets.sync.client import connect
with connect(sys.argv[1], subprotocols=['foxglove.sdk.v1'], max_size=None) as ws:
    while True:
        document = json.loads(ws.recv())
        if document['op'] == 'advertise':
            ws.send(json.dumps({'op': 'subscribe', 'subscriptions': [
                {'id': k + 1, 'channelId': c['id']} for k, c in enumerate(document['channels'])]}))
            break
    print('subscribed', flush=True)
    time.sleep(600)
"""


def test_a_client_that_stopped_reading_does_not_hold_the_stop(server):
    """A viewer frozen with messages queued for it (a page the browser no longer runs): the
    live view still stops within seconds (the launcher sends SIGTERM 6 s after SIGINT), not
    after websockets' 10 s closing handshake on each side of the relay."""
    client = subprocess.Popen([sys.executable, '-c', FROZEN_CLIENT, server.url],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert client.stdout.readline().strip() == 'subscribed'
        deadline = time.monotonic() + 30
        while not server.wanted(POSES):
            assert time.monotonic() < deadline
            time.sleep(0.05)
        os.kill(client.pid, signal.SIGSTOP)
        poses = pose_array_cdr([[1.0, 2.0, 0.5]] * 2000, NS)  # 100 kB: the pipes fill up
        for k in range(100):
            server.publish(POSES, NS + k, poses)
        time.sleep(1.0)
        started = time.monotonic()
        server.stop()
        took = time.monotonic() - started
    finally:
        client.kill()
        client.wait(10)
    assert took < 4.0, f'{took:.1f} s'
