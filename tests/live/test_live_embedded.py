"""``mona-swarm run --live``: a real Foxglove WebSocket client watches an embedded episode.

The client (tests/foxclient.py, the ``websockets`` package speaking the protocol)
connects, lists the advertised channels, subscribes to all, decodes every message with the
advertised ``ros2msg`` schemas, and checks what it saw against the episode and its bag. The
episode watched is the one the browser tier opens too (``embedded_live``, tests/liverun.py:
N = 12, seed 2, 200 s at pace 3, with a bag, among examples/obstacle_layout.yaml's obstacles,
lingering until its last test here is over, when Ctrl-C must end it with status 0, nothing
rewritten).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mona_controller.controllers.beeclust import STATES
from swarm_metrics.bags.reader import read_episode_bag
from swarm_supervisor.media.live import LIVE_TOPICS
from swarm_supervisor.media.recorded import read_record
from swarm_world.messages.markers import obstacles_from_markers

from foxclient import LEGACY_SUBPROTOCOL, Capture, connect_when_up

#: The shared run's pace (tests/liverun.py): sim seconds per wall second.
PACE = 3.0


def start_run(out: Path, *extra: str, linger: str = '0',
              duration: float = 2.0) -> tuple[subprocess.Popen, str]:
    """``mona-swarm run --live --live-port 0 --linger 0`` in a subprocess; (process, the URL it
    prints)."""
    process = subprocess.Popen(
        [sys.executable, '-m', 'swarm_supervisor.cli', 'run', '--population', '6',
         '--duration', str(duration), '--seed', '2', '--out', str(out), '--live', '--live-port',
         '0', '--linger', linger, *extra], stderr=subprocess.PIPE, stdout=subprocess.PIPE,
        text=True)
    for line in process.stderr:
        found = re.search(r'live view on (ws://\S+)', line)
        if found:
            return process, found.group(1)
    process.wait(10)
    pytest.fail(f'no live view announced; exit {process.returncode}')


@pytest.fixture
def watched(embedded_live) -> tuple[Capture, Path, str]:
    """(what a client saw from the start, the run's folder, its output) of the shared paced
    episode with a bag, among examples/obstacle_layout.yaml's obstacles (tests/liverun.py)."""
    return embedded_live.watched, embedded_live.out, embedded_live.run.output


def test_the_client_lists_every_channel_as_ros2_cdr(watched):
    seen, _, _ = watched
    assert seen.server_info['name'] == 'mona-swarm'
    assert 'time' in seen.server_info['capabilities']
    assert set(seen.channels) == set(LIVE_TOPICS)
    for topic, channel in seen.channels.items():
        assert (channel['encoding'], channel['schemaEncoding']) == ('cdr', 'ros2msg'), topic
        assert channel['schemaName'] == LIVE_TOPICS[topic]


def test_robots_arena_cue_and_sim_time(watched, embedded_live):
    seen, _, _ = watched
    population = embedded_live.population
    poses = seen.messages['/world/poses']
    assert all(len(msg.poses) == population for _, msg in poses)
    stamps = [msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec for _, msg in poses]
    assert stamps == [log_time for log_time, _ in poses]  # log time = sim time
    assert all(b > a for a, b in zip(stamps, stamps[1:]))  # sim time increases
    assert stamps[-1] - stamps[0] > 2e9
    assert all(b >= a for a, b in zip(seen.times, seen.times[1:])) and seen.times[-1] > 0
    for _, msg in seen.messages['/world/poses']:
        xy = np.array([(p.position.x, p.position.y) for p in msg.poses])
        assert ((xy > 0) & (xy < 2.85)).all()  # inside the arena
    markers = seen.messages['/world/markers'][-1][1].markers
    assert [m.id for m in markers] == list(range(population))
    colours = {tuple(round(c, 3) for c in state.colour) for state in STATES}
    assert {(round(m.color.r, 3), round(m.color.g, 3), round(m.color.b, 3),
             round(m.color.a, 3)) for m in markers} <= colours
    states = seen.messages['/world/robot_states'][-1][1]
    assert len(bytes(states.data)) == population
    image = seen.messages['/world/cue_map'][-1][1]
    assert (image.height, image.width, image.encoding) == (285, 285, 'mono8')
    grid = seen.messages['/world/cue_grid'][-1][1]
    assert grid.info.width == 285 and grid.info.resolution == pytest.approx(0.01)  # float32
    status = json.loads(seen.messages['/world/status'][-1][1].data)
    assert status['state'] in ('running', 'finished') and status['mode'] == 'embedded'


def test_the_obstacles_are_shown_as_the_bag_has_them(watched, embedded_live):
    """The layout's eight obstacles on /world/obstacles, live as in the bag."""
    seen, out, _ = watched
    log_time, msg = seen.messages['/world/obstacles'][-1]
    assert log_time == 0  # the episode's start, as in the bag
    assert [(m.ns, m.id, m.text) for m in msg.markers] == \
        [('obstacles', k, name) for k, name in enumerate(
            ['ring_0', 'ring_1', 'ring_2', 'ring_3', 'ring_4', 'ring_5', 'wall', 'wedge'])]
    assert [m.type for m in msg.markers] == [3] * 6 + [1, 11]  # cylinders, a cube, a prism
    # The same shapes as the video reads from the bag (closed once the episode has ended).
    embedded_live.wait_lingering()
    assert obstacles_from_markers(msg.markers) == read_record(out).obstacles


def test_live_equals_the_bag(watched, embedded_live):
    """The announcement and every metric sample seen live are the bag's."""
    seen, out, _ = watched
    embedded_live.wait_lingering()
    assert 'bag' in embedded_live.run.output
    bag = read_episode_bag(out / 'bag')
    announced = json.loads(seen.messages['/episode'][0][1].data)
    assert announced == bag.announcement
    assert announced['population'] == embedded_live.population
    for name in ('mean_cue', 'mean_cue_fraction', 'ratio_near_source', 'coherency'):
        recorded = dict(zip(*(values.tolist() for values in bag.metric(name))))
        live = [(t, msg.data) for t, msg in seen.messages[f'/metrics/{name}']]
        assert len(live) >= 3
        assert all(recorded[t] == value for t, value in live), name


def test_pace_holds_the_episode_to_a_multiple_of_real_time(embedded_live):
    embedded_live.wait_lingering()
    record = json.loads((embedded_live.out / 'episode.json').read_text())
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
             '--duration', '1', '--out', str(tmp_path / 'x'), '--live', '--live-port', port],
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


def test_a_viewer_who_connects_after_the_episode_sees_its_end(embedded_live):
    """The run ends, writes every output, and keeps serving the final state: a client that
    connects only then (offering only the protocol's older name) gets the finished status,
    the last poses, the cue map and the sources (Ctrl-C then exits 0 with nothing lost: the
    shared run's teardown)."""
    embedded_live.wait_lingering()
    out = embedded_live.out
    # Every output is complete before the linger starts.
    record = json.loads((out / 'episode.json').read_text())
    assert record['duration'] == embedded_live.duration and (out / 'metrics.csv').exists()
    assert read_episode_bag(out / 'bag').status[-1][1]['state'] == 'finished'
    seen = connect_when_up(embedded_live.url, seconds=20, done=final,
                           subprotocols=[LEGACY_SUBPROTOCOL])
    assert seen.subprotocol == LEGACY_SUBPROTOCOL
    assert final(seen), sorted(seen.messages)
    end_ns = round(embedded_live.duration * 1e9)
    log_time, poses = seen.messages['/world/poses'][-1]
    assert log_time >= end_ns and len(poses.poses) == embedded_live.population
    bag = read_episode_bag(out / 'bag')
    assert [(p.position.x, p.position.y) for p in poses.poses] == \
        [tuple(xy) for xy in bag.poses[-1][1][:, :2].tolist()]  # the bag's last poses
    assert seen.messages['/world/cue_map'][-1][0] == log_time
    assert embedded_live.run.process.poll() is None  # still serving


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


# --- before the episode: --wait-for-viewer --------------------------------------------------

#: The outputs of an episode that are the same bit for bit on every run of it (episode.json
#: also holds the wall time and the folder).
EXACT_OUTPUTS = ('metrics.csv', 'snapshots.npz', 'final_cue_map.png', 'bag/bag.mcap',
                 'bag/metadata.yaml')


def lists_channels(url: str) -> None:
    """Connect, read the server's info and its channels, and leave without subscribing."""
    from websockets.sync.client import connect

    with connect(url, subprotocols=[LEGACY_SUBPROTOCOL], open_timeout=30) as socket:
        ops = {json.loads(socket.recv(timeout=30))['op'] for _ in range(2)}
    assert ops == {'serverInfo', 'advertise'}


def test_wait_for_viewer_holds_the_episode_until_a_client_subscribes(tmp_path):
    """With --wait-for-viewer nothing runs, and nothing is written, until a client subscribes
    (one that only connects and lists the channels is no viewer); the client then sees the
    episode from t = 0, and the outputs are those of the same run without the option, bit
    for bit."""
    held, plain = tmp_path / 'held', tmp_path / 'plain'
    process, url = start_run(held, '--bag', '--wait-for-viewer', '300', duration=3.0)
    try:
        waiting = process.stderr.readline()
        assert f'waiting for a viewer on {url}' in waiting, waiting
        lists_channels(url)
        time.sleep(2.0)
        assert process.poll() is None and not held.exists()  # held: --out not even made
        seen = connect_when_up(url, seconds=120)  # subscribes to every channel
        _, stderr = process.communicate(timeout=120)
    finally:
        process.kill()
    assert process.returncode == 0, stderr
    assert 'a viewer has subscribed; the episode starts' in stderr
    statuses = [json.loads(msg.data) for _, msg in seen.messages['/world/status']]
    assert statuses[0]['step'] == 0 and statuses[-1]['state'] == 'finished'
    assert seen.messages['/world/poses'][0][0] == 0  # the episode's first frame, t = 0
    assert seen.messages['/episode'][0][0] == 0
    other, url = start_run(plain, '--bag', duration=3.0)  # no client: it runs at once
    _, stderr = other.communicate(timeout=120)
    assert other.returncode == 0, stderr
    for name in EXACT_OUTPUTS:
        assert (held / name).read_bytes() == (plain / name).read_bytes(), name


def test_wait_for_viewer_gives_up_when_no_viewer_comes(tmp_path):
    started = time.monotonic()
    process, url = start_run(tmp_path / 'run', '--wait-for-viewer', '1')
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == 124, stderr
    assert f'no viewer subscribed to the live view on {url} in 1 s (--wait-for-viewer)' \
        in stderr and 'Traceback' not in stderr
    assert not (tmp_path / 'run').exists()  # nothing written
    assert time.monotonic() - started < 100


def test_wait_for_viewer_without_live_is_refused(tmp_path):
    result = subprocess.run(
        [sys.executable, '-m', 'swarm_supervisor.cli', 'run', '--population', '3',
         '--duration', '1', '--out', str(tmp_path / 'x'), '--wait-for-viewer'],
        capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and '--wait-for-viewer is for --live' in result.stderr
    assert 'Traceback' not in result.stderr and not (tmp_path / 'x').exists()
