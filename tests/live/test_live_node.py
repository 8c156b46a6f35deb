"""``scripts/swarm.sh --live``: a real Foxglove WebSocket client watches the node system.

The live node forwards the recorded topics as the raw CDR the world, the supervisor and the
metrics node publish; the client decodes them with the advertised ``ros2msg`` schemas.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import sys
from pathlib import Path

import pytest

from mona_controller.controllers.beeclust import STATES
from swarm_supervisor.system.live_node import NODE_TOPICS

from foxclient import LEGACY_SUBPROTOCOL, Capture, connect_when_up

sys.path.insert(0, str(Path(__file__).parents[1] / 'system'))
from swarmrun import SwarmRun  # noqa: E402

pytestmark = pytest.mark.ros
POPULATION, DURATION = 4, 30.0


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def enough(capture: Capture) -> bool:
    return len(capture.messages.get('/world/poses', ())) >= 6 and \
        len(capture.messages.get('/metrics/coherency', ())) >= 3 and \
        '/world/cue_map' in capture.messages and '/episode' in capture.messages and \
        '/world/obstacles' in capture.messages


@pytest.fixture(scope='module')
def watched(tmp_path_factory: pytest.TempPathFactory) -> tuple[Capture, SwarmRun, int]:
    """(what the client saw, the run, its exit status)."""
    port = free_port()
    run = SwarmRun(tmp_path_factory.mktemp('live') / 'run',
                   ['--population', str(POPULATION), '--duration', str(DURATION),
                    '--seed', '3', '--live', '--live-port', str(port), '--linger', '0'])
    try:
        seen = connect_when_up(f'ws://127.0.0.1:{port}', timeout=120, seconds=120,
                               done=enough)
        status = run.wait()
    finally:
        run.stop()
    return seen, run, status


def test_the_run_with_a_live_view_succeeds_and_the_live_node_ends_by_itself(watched):
    _, run, status = watched
    assert status == 0, run.stderr
    assert 'live' in run.nodes()
    assert 'live view on ws://127.0.0.1:' in run.log('live')


def test_the_client_sees_the_swarm_with_ros2_schemas(watched):
    seen, _, _ = watched
    assert set(seen.channels) == set(NODE_TOPICS)
    for topic, channel in seen.channels.items():
        assert (channel['encoding'], channel['schemaEncoding']) == ('cdr', 'ros2msg'), topic
    poses = seen.messages['/world/poses']
    assert len(poses) >= 6 and all(len(msg.poses) == POPULATION for _, msg in poses)
    stamps = [msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec for _, msg in poses]
    assert all(b > a for a, b in zip(stamps, stamps[1:]))  # sim time increases
    assert stamps == [log_time for log_time, _ in poses]
    announced = json.loads(seen.messages['/episode'][0][1].data)
    assert announced['population'] == POPULATION and announced['seed'] == 3
    image = seen.messages['/world/cue_map'][-1][1]
    assert (image.height, image.width, image.encoding) == (285, 285, 'mono8')
    values = [msg.data for _, msg in seen.messages['/metrics/coherency']]
    assert all(0 < value < 4.1 for value in values)  # metres, inside a 2.85 m arena
    status = json.loads(seen.messages['/world/status'][-1][1].data)
    assert status['mode'] == 'lockstep'
    # The robot markers' log time is their stamp (a marker array has no header of its own).
    markers = seen.messages['/world/markers']
    assert markers and all(log_time == msg.markers[0].header.stamp.sec * 10**9
                           + msg.markers[0].header.stamp.nanosec for log_time, msg in markers)
    # The world's latched obstacles, repeated for the client: none in this arena.
    assert all(list(msg.markers) == [] for _, msg in seen.messages['/world/obstacles'])


def final(capture: Capture) -> bool:
    statuses = [json.loads(msg.data) for _, msg in capture.messages.get('/world/status', ())]
    return any(s['state'] == 'finished' for s in statuses) and \
        {'/world/poses', '/world/cue_map', '/world/sources', '/world/robot_states',
         '/world/markers', '/episode'} <= set(capture.messages)


def test_after_the_run_the_live_view_serves_its_final_state_until_ctrl_c(tmp_path):
    """swarm.sh --live: the run finishes, every record is complete, and the live node keeps
    serving the final state; a client that connects only then (offering only the protocol's
    older name) sees the finished status, the last poses and states, the cue map and the
    sources; Ctrl-C then ends the script with exit 0."""
    port = free_port()
    run = SwarmRun(tmp_path / 'run', ['--population', str(POPULATION), '--duration', '8',
                                      '--seed', '4', '--live', '--live-port', str(port)])
    try:
        run.wait_for(lambda: 'keeps serving its final state' in run.stderr, 'the linger')
        report = json.loads((run.out / 'run.json').read_text())
        assert (run.out / 'episode_0' / 'bag' / 'metadata.yaml').exists()  # closed
        seen = connect_when_up(f'ws://127.0.0.1:{port}', timeout=30, seconds=30, done=final,
                               subprotocols=[LEGACY_SUBPROTOCOL])
        assert seen.subprotocol == LEGACY_SUBPROTOCOL and final(seen), (
            sorted(seen.messages),
            [json.loads(m.data)['state'] for _, m in seen.messages.get('/world/status', ())])
        log_time, poses = seen.messages['/world/poses'][-1]
        assert log_time >= 8 * 10**9 and len(poses.poses) == POPULATION  # the end's poses
        states = bytes(seen.messages['/world/robot_states'][-1][1].data)
        assert len(states) == POPULATION
        # The world's markers are coloured by the states it gathers (the embedded colours).
        markers = seen.messages['/world/markers'][-1][1].markers
        assert [(round(m.color.r, 3), round(m.color.g, 3), round(m.color.b, 3))
                for m in markers] == [tuple(round(c, 3) for c in STATES[s].colour[:3])
                                      for s in states]
        assert run.process.poll() is None  # still serving
        os.killpg(run.process.pid, signal.SIGINT)
        status = run.wait(60)
    finally:
        run.stop()
    assert status == 0, run.stderr
    assert 'done:' in run.stderr and 'FAILED' not in run.stderr
    assert json.loads((run.out / 'run.json').read_text()) == report  # nothing rewritten
