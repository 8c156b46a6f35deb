"""Obstacles in the record: an embedded episode among obstacles holds /world/obstacles, read by
an independent decoder (mcap-ros2-support) with the layout's shapes and poses; a run without
obstacles holds an empty array; the video of the bag shows the obstacles as grey shapes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import imageio.v2 as imageio
import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.media.video import OBSTACLE_FILL, Renderer, animate, read_record
from swarm_supervisor.outputs.bag import record_episode
from swarm_world.messages.markers import HEIGHT, obstacles_from_markers

#: One of each kind, clear of the source at the centre (docs/extending.md's example shapes).
OBSTACLES = {'pillar': [1.0, 1.0, 0.12], 'wall': [2.2, 0.3, 2.3, 1.1],
             'wedge': [0.3, 2.2, 0.8, 2.45, 0.35, 2.65]}
CONFIG = SwarmConfig().replace(world={'obstacles': OBSTACLES},
                               episode={'population': 10, 'duration': 20.0, 'seed': 3})
START_NS = 5_000_000_000


@pytest.fixture(scope='module')
def episode(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An episode folder holding the embedded bag of an episode among obstacles (its t = 0 at
    5 s of sim time, as a second episode's would be)."""
    from swarm_supervisor.engine.runner import run_episode
    from swarm_supervisor.outputs.bag import BagRecorder

    folder = tmp_path_factory.mktemp('obstacles')
    recorder = BagRecorder(folder, episode=1, start_ns=START_NS)
    recorder.check(run_episode(CONFIG, observers=[recorder]))
    return folder


def decoded(bag: Path) -> dict[str, list[tuple[int, object]]]:
    """topic -> [(log time, message)], by mcap-ros2-support."""
    out: dict[str, list[tuple[int, object]]] = {}
    with open(next(bag.glob('*.mcap')), 'rb') as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        for _, channel, message, msg in reader.iter_decoded_messages():
            out.setdefault(channel.topic, []).append((message.log_time, msg))
    return out


def test_the_bag_holds_the_obstacles_once_at_the_episode_start(episode):
    messages = decoded(episode / 'bag')
    (log_ns, msg), = messages['/world/obstacles']
    assert log_ns == START_NS == json.loads(messages['/episode'][0][1].data)['start_ns']
    pillar, wall, wedge = msg.markers
    for k, marker in enumerate(msg.markers):
        assert (marker.ns, marker.id, marker.action, marker.header.frame_id) == \
            ('obstacles', k, 0, 'world')
        assert (marker.header.stamp.sec, marker.header.stamp.nanosec) == (0, 0)
        assert (marker.color.r, marker.color.g, marker.color.b, marker.color.a) == \
            (0.5, 0.5, 0.5, 1.0)
        assert marker.pose.orientation.w == 1.0
    assert (pillar.text, pillar.type) == ('pillar', 3)  # CYLINDER
    assert (pillar.pose.position.x, pillar.pose.position.y, pillar.pose.position.z) == \
        (1.0, 1.0, HEIGHT / 2)
    assert (pillar.scale.x, pillar.scale.y, pillar.scale.z) == (0.24, 0.24, HEIGHT)
    assert (wall.text, wall.type) == ('wall', 1)  # CUBE
    assert (wall.pose.position.x, wall.pose.position.y) == pytest.approx((2.25, 0.7))
    assert (wall.scale.x, wall.scale.y, wall.scale.z) == pytest.approx((0.1, 0.8, HEIGHT))
    assert (wedge.text, wedge.type) == ('wedge', 11)  # TRIANGLE_LIST
    assert len(wedge.points) == 3 * (3 * 3 - 2)  # the top and three walls of a triangle
    shapes = obstacles_from_markers(msg.markers)
    assert shapes[0] == CONFIG.world.arena().obstacles[0]
    assert shapes[2] == CONFIG.world.arena().obstacles[2]  # the wedge, counter-clockwise


def test_a_run_without_obstacles_records_an_empty_array(tmp_path):
    config = SwarmConfig().replace(episode={'population': 3, 'duration': 2.0, 'seed': 1})
    _, closed = record_episode(config, tmp_path)
    (log_ns, msg), = decoded(closed.path)['/world/obstacles']
    assert log_ns == 0 and list(msg.markers) == []


def test_the_bag_analyses_as_any(episode, tmp_path):
    result = subprocess.run([sys.executable, '-m', 'swarm_supervisor.cli', 'analyze',
                             str(episode / 'bag'), '--out', str(tmp_path / 'analysed')],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'online metrics agree to 0' in result.stdout


def test_video_frames_show_the_obstacles_in_grey(episode):
    record = read_record(episode)
    assert [o.name for o in record.obstacles] == list(OBSTACLES)
    out = episode / 'episode.mp4'
    animate(episode, out, speedup=10.0, fps=5.0, width=640)
    renderer = Renderer(record, width=640)
    top, left, h, w = renderer.map_box
    arena = CONFIG.world.arena_side
    rows, cols = np.mgrid[0:h, 0:w]
    xs, ys = (cols + 0.5) / w * arena, (1 - (rows + 0.5) / h) * arena
    frame = next(iter(imageio.get_reader(out)))  # the encoded video, read back
    exact = renderer.render(0)
    for obstacle in record.obstacles:
        # Well inside the shape (H.264 blurs its edges): the obstacles' grey, robots aside.
        inside = obstacle.covers(xs, ys) & (np.vectorize(obstacle.clearance)(xs, ys) < -0.02)
        assert inside.sum() > 20, obstacle.name
        shown = frame[top:top + h, left:left + w][inside].astype(int)
        assert np.median(np.abs(shown - OBSTACLE_FILL), axis=0).max() <= 6, obstacle.name
        assert (exact[top:top + h, left:left + w][inside] == OBSTACLE_FILL).all(axis=1).mean() \
            > 0.9, obstacle.name
    # Nowhere else is the map that grey: the cue's colours are viridis's.
    on_map = exact[top:top + h, left:left + w]
    grey = (on_map == OBSTACLE_FILL).all(axis=2)
    covered = np.zeros((h, w), dtype=bool)
    for obstacle in record.obstacles:
        covered |= obstacle.covers(xs, ys)
    assert grey.any() and not (grey & ~covered).any()
