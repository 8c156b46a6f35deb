"""The launcher's progress line and the supervisor's progress.json behind it
(swarm_supervisor.system.progress), without ROS."""

from __future__ import annotations

import json
from pathlib import Path

from mona_controller.contract import WorldState, WorldStatus
from swarm_supervisor.system.progress import (
    ProgressFile,
    ProgressLine,
    duration_text,
    read_progress,
)


def status(episode: int, step: int, state: WorldState = WorldState.RUNNING) -> WorldStatus:
    return WorldStatus(episode=episode, state=state, step=step, steps=6000,
                       misses=(1, 0, 2), absent=(2,))


def test_the_file_is_written_at_most_once_a_second_and_at_each_change(tmp_path: Path):
    progress = ProgressFile(tmp_path, episodes=2, duration=600.0)
    assert progress.note(status(0, 10))
    assert not progress.note(status(0, 20))  # too soon
    assert progress.note(status(0, 6000, WorldState.FINISHED))  # a change of state
    document = read_progress(tmp_path)
    assert document is not None
    assert {k: document[k] for k in ('episode', 'episodes', 'state', 'step', 'steps',
                                     'duration', 'misses', 'absent')} == \
        {'episode': 0, 'episodes': 2, 'state': 'finished', 'step': 6000, 'steps': 6000,
         'duration': 600.0, 'misses': 3, 'absent': 1}
    assert [p.name for p in tmp_path.iterdir()] == ['progress.json']  # no partial left


def test_no_or_a_broken_file_reads_as_none(tmp_path: Path):
    assert read_progress(tmp_path) is None
    (tmp_path / 'progress.json').write_text('{"episode": ')
    assert read_progress(tmp_path) is None


def document(episode: int, step: int, wall: float, state: str = 'running') -> dict:
    return {'episode': episode, 'episodes': 2, 'state': state, 'step': step, 'steps': 6000,
            'duration': 600.0, 'misses': 3, 'absent': 1, 'wall': wall}


def test_the_line_says_episode_sim_time_speed_misses_and_eta():
    line = ProgressLine()
    assert line.line(None, 12.0) == 'waiting for the world (12 s since the start)'
    assert line.line(document(-1, 0, 100.0, 'waiting'), 20.0) == (
        'episode 1/2: waiting for the controllers and the metrics node (20 s since the start)')
    assert line.line(document(0, 1200, 100.0), 30.0) == 'episode 1/2, sim 120/600 s, 3 misses'
    # 10 wall seconds later, 850 steps more: 85 steps/s, 12000 - 2050 steps to go.
    assert line.line(document(0, 2050, 110.0), 40.0) == (
        'episode 1/2, sim 205/600 s, 85 steps/s, 3 misses, ETA 1 min 57 s')
    assert line.line(json.loads(json.dumps(document(1, 0, 120.0))), 50.0).startswith(
        'episode 2/2, sim 0/600 s, 395 steps/s')
    assert line.line({'episode': 'x'}, 60.0) == 'no progress (unreadable progress.json)'


def test_durations_read_naturally():
    assert [duration_text(s) for s in (4.4, 59.6, 565, 7500)] == \
        ['4 s', '1 min 0 s', '9 min 25 s', '2 h 05 min']
