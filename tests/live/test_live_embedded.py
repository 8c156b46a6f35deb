"""``mona-swarm run --live``: a real Foxglove WebSocket client watches an embedded episode.

The client (tests/live/foxclient.py, the ``websockets`` package speaking the protocol)
connects, lists the advertised channels, subscribes to all, decodes every message with the
advertised ``ros2msg`` schemas, and checks what it saw against the episode and its bag.
"""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mona_controller.controllers.beeclust import STATES
from swarm_metrics.bag_reader import read_episode_bag
from swarm_supervisor.media.live import LIVE_TOPICS
from swarm_supervisor.media.recorded import read_record
from swarm_world.arena_markers import obstacles_from_markers

from foxclient import LEGACY_SUBPROTOCOL, Capture, connect_when_up

POPULATION, DURATION, PACE = 6, 60.0, 12.0
#: The watched episode runs among the obstacles of docs/extending.md's example layout.
LAYOUT = Path(__file__).parents[2] / 'examples' / 'obstacle_layout.yaml'


def start_run(out: Path, *extra: str, linger: str = '0',
              duration: float = DURATION) -> tuple[subprocess.Popen, str]:
    """``mona-swarm run --live --port 0 --linger 0`` in a subprocess; (process, the URL it
    prints)."""
    process = subprocess.Popen(
        [sys.executable, '-m', 'swarm_supervisor.cli', 'run', '--population', str(POPULATION),
         '--duration', str(duration), '--seed', '2', '--out', str(out), '--live', '--port',
         '0', '--linger', linger, *extra], stderr=subprocess.PIPE, stdout=subprocess.PIPE,
        text=True)
    for line in process.stderr:
        found = re.search(r'live view on (ws://\S+)', line)
        if found:
            return process, found.group(1)
    process.wait(10)
    pytest.fail(f'no live view announced; exit {process.returncode}')


def enough(capture: Capture) -> bool:
    return len(capture.messages.get('/world/poses', ())) >= 8 and \
        len(capture.messages.get('/metrics/coherency', ())) >= 3 and \
        '/world/cue_map' in capture.messages and '/episode' in capture.messages and \
        '/world/obstacles' in capture.messages


@pytest.fixture(scope='module')
def watched(tmp_path_factory: pytest.TempPathFactory) -> tuple[Capture, Path, str]:
    """(what the client saw, the run's folder, its stdout) of a paced episode with a bag."""
    out = tmp_path_factory.mktemp('live') / 'run'
    process, url = start_run(out, '--pace', str(PACE), '--bag', '--config', str(LAYOUT))
    try:
        seen = connect_when_up(url, seconds=30, done=enough)
        stdout, stderr = process.communicate(timeout=120)
    finally:
        process.kill()
    assert process.returncode == 0, stderr
    return seen, out, stdout


def test_the_client_lists_every_channel_as_ros2_cdr(watched):
    seen, _, _ = watched
    assert seen.server_info['name'] == 'mona-swarm'
    assert 'time' in seen.server_info['capabilities']
    assert set(seen.channels) == set(LIVE_TOPICS)
    for topic, channel in seen.channels.items():
        assert (channel['encoding'], channel['schemaEncoding']) == ('cdr', 'ros2msg'), topic
        assert channel['schemaName'] == LIVE_TOPICS[topic]


def test_robots_arena_cue_and_sim_time(watched):
    seen, _, _ = watched
    poses = seen.messages['/world/poses']
    assert all(len(msg.poses) == POPULATION for _, msg in poses)
    stamps = [msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec for _, msg in poses]
    assert stamps == [log_time for log_time, _ in poses]  # log time = sim time
    assert all(b > a for a, b in zip(stamps, stamps[1:]))  # sim time increases
    assert stamps[-1] - stamps[0] > 2e9
    assert all(b >= a for a, b in zip(seen.times, seen.times[1:])) and seen.times[-1] > 0
    for _, msg in seen.messages['/world/poses']:
        xy = np.array([(p.position.x, p.position.y) for p in msg.poses])
        assert ((xy > 0) & (xy < 2.85)).all()  # inside the arena
    markers = seen.messages['/world/markers'][-1][1].markers
    assert [m.id for m in markers] == list(range(POPULATION))
    colours = {tuple(round(c, 3) for c in state.colour) for state in STATES}
    assert {(round(m.color.r, 3), round(m.color.g, 3), round(m.color.b, 3),
             round(m.color.a, 3)) for m in markers} <= colours
    states = seen.messages['/world/robot_states'][-1][1]
    assert len(bytes(states.data)) == POPULATION
    image = seen.messages['/world/cue_map'][-1][1]
    assert (image.height, image.width, image.encoding) == (285, 285, 'mono8')
    grid = seen.messages['/world/cue_grid'][-1][1]
    assert grid.info.width == 285 and grid.info.resolution == pytest.approx(0.01)  # float32
    status = json.loads(seen.messages['/world/status'][-1][1].data)
    assert status['state'] in ('running', 'finished') and status['mode'] == 'embedded'


def test_the_obstacles_are_shown_as_the_bag_has_them(watched):
    """The layout's eight obstacles on /world/obstacles, live as in the bag."""
    seen, out, _ = watched
    log_time, msg = seen.messages['/world/obstacles'][-1]
    assert log_time == 0  # the episode's start, as in the bag
    assert [(m.ns, m.id, m.text) for m in msg.markers] == \
        [('obstacles', k, name) for k, name in enumerate(
            ['ring_0', 'ring_1', 'ring_2', 'ring_3', 'ring_4', 'ring_5', 'wall', 'wedge'])]
    assert [m.type for m in msg.markers] == [3] * 6 + [1, 11]  # cylinders, a cube, a prism
    # The same shapes as the video reads from the bag.
    assert obstacles_from_markers(msg.markers) == read_record(out).obstacles


def test_live_equals_the_bag(watched):
    """The announcement and every metric sample seen live are the bag's."""
    seen, out, stdout = watched
    assert 'bag' in stdout
    bag = read_episode_bag(out / 'bag')
    announced = json.loads(seen.messages['/episode'][0][1].data)
    assert announced == bag.announcement
    assert announced['population'] == POPULATION
    for name in ('mean_cue', 'mean_cue_fraction', 'ratio_near_source', 'coherency'):
        recorded = dict(zip(*(values.tolist() for values in bag.metric(name))))
        live = [(t, msg.data) for t, msg in seen.messages[f'/metrics/{name}']]
        assert len(live) >= 3
        assert all(recorded[t] == value for t, value in live), name


def test_pace_holds_the_episode_to_a_multiple_of_real_time(watched):
    _, out, _ = watched
    record = json.loads((out / 'episode.json').read_text())
    assert PACE * 0.8 < record['real_time_factor'] <= PACE * 1.05


def test_a_taken_port_is_an_error_naming_it(tmp_path):
    blocker = subprocess.Popen(
        [sys.executable, '-c', 'import socket, time; s = socket.socket(); '
         's.bind(("127.0.0.1", 0)); s.listen(); print(s.getsockname()[1], flush=True); '
         'time.sleep(60)'], stdout=subprocess.PIPE, text=True)
    try:
        port = blocker.stdout.readline().strip()
        result = subprocess.run(
            [sys.executable, '-m', 'swarm_supervisor.cli', 'run', '--population', '3',
             '--duration', '1', '--out', str(tmp_path / 'x'), '--live', '--port', port],
            capture_output=True, text=True, timeout=120)
    finally:
        blocker.kill()
    assert result.returncode == 2
    assert f'127.0.0.1:{port}' in result.stderr


# --- after the episode: --linger ------------------------------------------------------------

def wait_for_linger(process: subprocess.Popen) -> None:
    for line in process.stderr:
        if 'keeps serving its final state' in line:
            return
    pytest.fail(f'the run never lingered; exit {process.wait(10)}')


def final(capture: Capture) -> bool:
    statuses = [json.loads(msg.data) for _, msg in capture.messages.get('/world/status', ())]
    return any(s['state'] == 'finished' for s in statuses) and \
        '/world/poses' in capture.messages and '/world/sources' in capture.messages and \
        '/world/cue_map' in capture.messages and '/episode' in capture.messages


def test_a_viewer_who_connects_after_the_episode_sees_its_end_until_ctrl_c(tmp_path):
    """The run ends, writes every output, and keeps serving the final state: a client that
    connects only then (offering only the protocol's older name) gets the finished status,
    the last poses, the cue map and the sources; Ctrl-C then exits 0 with nothing lost."""
    out = tmp_path / 'run'
    process, url = start_run(out, '--bag', linger='600', duration=8.0)
    try:
        wait_for_linger(process)
        # Every output is complete before the linger starts.
        record = json.loads((out / 'episode.json').read_text())
        assert record['duration'] == 8.0 and (out / 'metrics.csv').exists()
        seen = connect_when_up(url, seconds=20, done=final, subprotocols=[LEGACY_SUBPROTOCOL])
        assert seen.subprotocol == LEGACY_SUBPROTOCOL
        assert final(seen), sorted(seen.messages)
        end_ns = round(8.0 * 1e9)
        log_time, poses = seen.messages['/world/poses'][-1]
        assert log_time >= end_ns and len(poses.poses) == POPULATION
        bag = read_episode_bag(out / 'bag')
        assert [(p.position.x, p.position.y) for p in poses.poses] == \
            [tuple(xy) for xy in bag.poses[-1][1][:, :2].tolist()]  # the bag's last poses
        assert seen.messages['/world/cue_map'][-1][0] == log_time
        assert process.poll() is None  # still serving
        process.send_signal(signal.SIGINT)
        stdout, stderr = process.communicate(timeout=30)
    finally:
        process.kill()
    assert process.returncode == 0, stderr
    assert 'live view closed' in stderr and 'Traceback' not in stderr
    assert json.loads((out / 'episode.json').read_text()) == record  # nothing rewritten
    assert read_episode_bag(out / 'bag').status[-1][1]['state'] == 'finished'


def test_linger_seconds_ends_by_itself(tmp_path):
    started = time.monotonic()
    process, url = start_run(tmp_path / 'run', linger='2', duration=2.0)
    try:
        wait_for_linger(process)
        lingered = time.monotonic()
        seen = connect_when_up(url, seconds=10, done=final)
        assert final(seen)
        _, stderr = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 0, stderr
    assert 1.5 < time.monotonic() - lingered and time.monotonic() - started < 60
    assert (tmp_path / 'run' / 'metrics.csv').exists()


def test_linger_without_live_is_refused(tmp_path):
    result = subprocess.run(
        [sys.executable, '-m', 'swarm_supervisor.cli', 'run', '--population', '3',
         '--duration', '1', '--out', str(tmp_path / 'x'), '--linger', '5'],
        capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and '--linger is for --live' in result.stderr
    assert 'Traceback' not in result.stderr and not (tmp_path / 'x').exists()
