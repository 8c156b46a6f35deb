"""``scripts/swarm.sh --live``: a real Foxglove WebSocket client watches the node system.

The live node forwards the recorded topics as the raw CDR the world, the supervisor and the
metrics node publish; the client decodes them with the advertised ``ros2msg`` schemas. The
run watched is the one the browser tier opens too (``node_live``, tests/liverun.py: lockstep,
N = 5, seed 4, 80 s, among examples/obstacle_layout.yaml's obstacles, lingering until its
last test here is over, when Ctrl-C must end it with status 0 and nothing rewritten).
"""

from __future__ import annotations

import json
import os
import signal
import time

import pytest

from mona_controller.controllers.beeclust import STATES
from swarm_supervisor.system.processes import LIVE_READY
from swarm_supervisor.system.ros.live_node import NODE_TOPICS

from foxclient import LEGACY_SUBPROTOCOL, Capture, connect_when_up
from harness import free_port
from swarmrun import SwarmRun

pytestmark = [pytest.mark.ros]
#: examples/obstacle_layout.yaml's obstacles, in name order.
OBSTACLES = ['ring_0', 'ring_1', 'ring_2', 'ring_3', 'ring_4', 'ring_5', 'wall', 'wedge']


def test_a_run_with_a_live_view_and_no_linger_ends_by_itself(tmp_path):
    """``--linger 0``: the live node ends with the run, which exits 0 by itself."""
    port = free_port()
    run = SwarmRun(tmp_path / 'run', ['--population', '2', '--duration', '4', '--seed', '3',
                                      '--live', '--live-port', str(port), '--linger', '0'])
    try:
        status = run.wait()
    finally:
        run.stop()
    assert status == 0, run.stderr
    assert 'live' in run.nodes()
    assert f'live view on ws://127.0.0.1:{port}' in run.log('live')
    assert 'keeps serving' not in run.stderr


def test_no_episode_starts_or_ends_without_the_live_view(tmp_path):
    """A live node slow to start (stopped here, as a busy machine may keep it) holds the first
    episode back: the world's per-step topics are kept for no late subscriber, so a live view
    that joined after the episode would have no final state to serve (it had none at all).
    Stopped again from the announcement until after the world finished, it holds the run back
    too: the supervisor waits for its word that it holds the final state (before, the run
    shut down without it, and the live view served nothing while the script said it did)."""
    port = free_port()
    run = SwarmRun(tmp_path / 'run', ['--population', '2', '--duration', '4', '--seed', '3',
                                      '--live', '--live-port', str(port), '--linger', '60'])
    try:
        run.wait_for(lambda: 'live' in run.nodes(), 'the live node', timeout=60)
        live = run.nodes()['live']
        os.killpg(live, signal.SIGSTOP)
        try:
            run.wait_for(lambda: 'controller_1' in run.nodes(), 'the controllers', timeout=60)
            time.sleep(8.0)
            assert 'supervisor' not in run.nodes(), run.stderr  # no announcement: no episode
        finally:
            os.killpg(live, signal.SIGCONT)
        run.wait_for(lambda: 'supervisor' in run.nodes(), 'the supervisor', timeout=60)
        os.killpg(live, signal.SIGSTOP)  # before its announcement, until after the end
        try:
            run.wait_for(lambda: 'episode 0 finished' in run.log('world'), 'the episode')
            time.sleep(3.0)
            assert 'episode 0 finished' not in run.log('supervisor'), run.log('supervisor')
        finally:
            os.killpg(live, signal.SIGCONT)
        run.wait_for(lambda: 'keeps serving its final state' in run.stderr, 'the linger')
        seen = connect_when_up(f'ws://127.0.0.1:{port}', timeout=30, seconds=30, done=final)
        assert final(seen), sorted(seen.messages)
        assert LIVE_READY in run.log('live')
        os.killpg(run.process.pid, signal.SIGINT)
        status = run.wait(60)
    finally:
        run.stop()
    assert status == 0, run.stderr


def test_the_client_sees_the_swarm_with_ros2_schemas(node_live):
    seen = node_live.watched
    assert set(seen.channels) == set(NODE_TOPICS)
    for topic, channel in seen.channels.items():
        assert (channel['encoding'], channel['schemaEncoding']) == ('cdr', 'ros2msg'), topic
    poses = seen.messages['/world/poses']
    assert len(poses) >= 6 and all(len(msg.poses) == node_live.population for _, msg in poses)
    stamps = [msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec for _, msg in poses]
    assert all(b > a for a, b in zip(stamps, stamps[1:]))  # sim time increases
    assert stamps == [log_time for log_time, _ in poses]
    announced = json.loads(seen.messages['/episode'][0][1].data)
    assert announced['population'] == node_live.population
    assert announced['seed'] == node_live.seed
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
    # The world's latched obstacles, repeated for the client: the layout's, in name order.
    for _, msg in seen.messages['/world/obstacles']:
        assert [(m.ns, m.id, m.text) for m in msg.markers] == \
            [('obstacles', k, name) for k, name in enumerate(OBSTACLES)]


def final(capture: Capture) -> bool:
    statuses = [json.loads(msg.data) for _, msg in capture.messages.get('/world/status', ())]
    return any(s['state'] == 'finished' for s in statuses) and \
        {'/world/poses', '/world/cue_map', '/world/sources', '/world/robot_states',
         '/world/markers', '/episode'} <= set(capture.messages)


def test_after_the_run_the_live_view_serves_its_final_state(node_live):
    """swarm.sh --live: the run finishes, every record is complete, and the live node keeps
    serving the final state; a client that connects only then (offering only the protocol's
    older name) sees the finished status, the last poses and states, the cue map and the
    sources (Ctrl-C then ends the script with exit 0: the shared run's teardown)."""
    node_live.wait_lingering()
    run = node_live.run
    assert json.loads((run.out / 'run.json').read_text())['episodes']  # the report is written
    assert (run.out / 'episode_0' / 'bag' / 'metadata.yaml').exists()  # closed
    seen = connect_when_up(node_live.url, timeout=30, seconds=30, done=final,
                           subprotocols=[LEGACY_SUBPROTOCOL])
    assert seen.subprotocol == LEGACY_SUBPROTOCOL and final(seen), (
        sorted(seen.messages),
        [json.loads(m.data)['state'] for _, m in seen.messages.get('/world/status', ())])
    log_time, poses = seen.messages['/world/poses'][-1]
    end_ns = round(node_live.duration * 1e9)
    assert log_time >= end_ns and len(poses.poses) == node_live.population  # the end's poses
    states = bytes(seen.messages['/world/robot_states'][-1][1].data)
    assert len(states) == node_live.population
    # The world's markers are coloured by the states it gathers (the embedded colours).
    markers = seen.messages['/world/markers'][-1][1].markers
    assert [(round(m.color.r, 3), round(m.color.g, 3), round(m.color.b, 3))
            for m in markers] == [tuple(round(c, 3) for c in STATES[s].colour[:3])
                                  for s in states]
    assert run.process.poll() is None  # still serving
