"""``mona-swarm animate``: a video of a real (embedded) episode's bag, frame by frame."""

from __future__ import annotations

import collections
import subprocess
import sys
from pathlib import Path

import imageio.v2 as imageio
import imageio_ffmpeg
import numpy as np
import pytest

from swarm_supervisor.config import load_config
from swarm_supervisor.media.video import Renderer, animate, frame_times, read_record
from swarm_supervisor.outputs.bag import record_episode

CONFIG = load_config().replace(episode={'population': 20, 'duration': 160.0, 'seed': 4})
SPEEDUP, FPS = 8.0, 10.0


@pytest.fixture(scope='module')
def episode(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An episode folder holding the bag of a 160 s, 20-robot embedded episode."""
    folder = tmp_path_factory.mktemp('episode')
    record_episode(CONFIG, folder)
    return folder


@pytest.fixture(scope='module')
def video(episode: Path) -> tuple[Path, dict]:
    out = episode / 'episode.mp4'
    return out, animate(episode, out, speedup=SPEEDUP, fps=FPS, width=640)


def test_frame_count_is_duration_over_speedup_times_fps(video):
    path, written = video
    frames, _ = imageio_ffmpeg.count_frames_and_secs(str(path))
    assert frames == written['frames'] == round(160.0 / SPEEDUP * FPS)
    assert (written['width'], written['height']) == (640, 352)


def test_frames_change_as_the_episode_unfolds(video):
    path, _ = video
    changed, first, previous = [], None, None
    for frame in imageio.get_reader(path):  # streamed: a few frames in memory at a time
        frame = frame.astype(np.int16)
        if previous is None:
            first = frame
        else:
            changed.append(np.abs(frame - previous).mean() > 0.05)
        previous = frame
    assert sum(changed) >= 0.9 * len(changed)  # the clock and progress bar move every frame
    assert np.abs(first - previous).mean() > 1.0


def robot_pixels(renderer: Renderer, poses: np.ndarray) -> np.ndarray:
    """A mask of the map pixels within a robot's drawn disc."""
    _, _, h, w = renderer.map_box
    arena = renderer.record.setup.world.arena_side
    rows, cols = np.mgrid[0:h, 0:w]
    x, y = cols / w * arena, (1 - rows / h) * arena
    near = np.zeros((h, w), dtype=bool)
    radius = (renderer.record.setup.mona.body_radius + 2.5 * arena / w)
    for px, py, _ in poses:
        near |= np.hypot(x - px, y - py) <= radius
    return near


def test_first_and_last_frames_show_the_first_and_last_cue_snapshots(episode, video):
    record = read_record(episode)
    renderer = Renderer(record, width=640)
    times = frame_times(record.duration_ns, SPEEDUP, FPS)
    top, left, h, w = renderer.map_box
    (first_t, first_map), (last_t, last_map) = record.cue_maps[0], record.cue_maps[-1]
    assert first_t == times[0] == 0 and last_t == times[-1] == record.duration_ns
    assert np.abs(first_map.astype(int) - last_map).max() > 0  # the swarm cleaned
    first_frame = next(iter(imageio.get_reader(video[0])))
    last_frame = collections.deque(imageio.get_reader(video[0]), maxlen=1)[0]
    for t, snapshot, poses, shown in ((times[0], first_map, record.poses[0], first_frame),
                                      (times[-1], last_map, record.poses[-1], last_frame)):
        frame = renderer.render(int(t))
        on_map = frame[top:top + h, left:left + w]
        differ = (on_map != renderer.map_pixels(snapshot)).any(axis=2)
        assert differ.any()  # the robots are drawn
        assert not (differ & ~robot_pixels(renderer, poses)).any()  # and nothing else differs
        # The encoded frame is that frame, up to H.264's loss.
        assert np.abs(shown.astype(int) - frame).mean() < 4
    other = renderer.map_pixels(first_map)
    assert (other != renderer.map_pixels(last_map)).any()


def test_gif_and_the_command_line(episode, tmp_path):
    out = tmp_path / 'episode.gif'
    result = subprocess.run([sys.executable, '-m', 'swarm_supervisor.cli', 'animate',
                             str(episode), '--out', str(out), '--speedup', '40', '--fps', '5'],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert '20 frames' in result.stdout
    assert len(imageio.mimread(out)) == 20
    missing = subprocess.run([sys.executable, '-m', 'swarm_supervisor.cli', 'animate',
                              str(tmp_path), '--out', str(tmp_path / 'x.mp4')],
                             capture_output=True, text=True, timeout=120)
    assert missing.returncode == 2
    assert 'holds no bag' in missing.stderr and not (tmp_path / 'x.mp4').exists()


def test_a_still_is_the_frame_at_its_time_and_a_bad_time_is_refused(episode, tmp_path):
    record = read_record(episode)
    out = tmp_path / 'still.png'
    written = animate(episode, out, at=80.0, width=960)
    still = imageio.imread(out)[..., :3]
    expected = Renderer(record, width=960).render(80_000_000_000)
    assert written['frames'] == 1 and written['first_s'] == 80.0
    assert still.shape == expected.shape == (544, 960, 3)  # height 9/16, a multiple of 16
    assert (still == expected).all()  # PNG is lossless: exactly the frame at 80 s
    # The command line: the end by default; a time outside the episode, or a time for a
    # video, refused with nothing written.
    end = tmp_path / 'end.png'
    result = subprocess.run([sys.executable, '-m', 'swarm_supervisor.cli', 'animate',
                             str(episode), '--out', str(end)],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert 'a still (1280x720) at t = 160 s of 160 s' in result.stdout
    for args, says in ((['--out', str(tmp_path / 'late.png'), '--at', '161'], 'outside'),
                       (['--out', str(tmp_path / 'v.gif'), '--at', '5'], 'for a still (.png)')):
        refused = subprocess.run([sys.executable, '-m', 'swarm_supervisor.cli', 'animate',
                                  str(episode), *args], capture_output=True, text=True,
                                 timeout=120)
        assert refused.returncode == 2 and says in refused.stderr, refused.stderr
        assert not Path(args[1]).exists()
