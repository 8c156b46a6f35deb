"""Invariants and behaviour over real episodes of the embedded runner."""

import subprocess
import sys

import numpy as np
import pytest

from mona_controller.controllers.beeclust import WAIT
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import Episode
from swarm_supervisor.engine.runner import run_episode
from swarm_supervisor.outputs.episode_folder import write_episode

SIDE, RADIUS = 2.85, 0.04


def stepped(config, steps):
    """Yield (world, controllers, command) after each step of an episode."""
    episode = Episode(config)
    for _ in range(steps):
        command = episode.step().command
        yield episode.world, episode.controllers, command


def test_invariants_over_an_episode():
    config = SwarmConfig().replace(episode={'population': 30, 'seed': 11})
    steps = 120 * 31  # about two minutes of sim time
    previous_cue = None
    previous_poses = None
    previous_waiting = np.zeros(30, dtype=bool)
    wait_travel = 0.0
    wait_steps = 0
    worst_overlap = 0.0
    for k, (world, controllers, command) in enumerate(stepped(config, steps)):
        poses = world.poses
        # No robot leaves the arena (up to pymunk's collision slop).
        assert poses[:, :2].min() >= RADIUS - 1e-3
        assert poses[:, :2].max() <= SIDE - RADIUS + 1e-3
        # Robots do not interpenetrate beyond a small tolerance.
        delta = poses[:, None, :2] - poses[None, :, :2]
        distance = np.hypot(delta[..., 0], delta[..., 1]) + np.eye(30)
        worst_overlap = max(worst_overlap, 2 * RADIUS - distance.min())
        # A waiting robot does not turn and moves only when pushed (a one-step actuation
        # delay: a robot that waited at the last step has no drive now).
        waiting = previous_waiting & command.cleaner
        if previous_poses is not None and waiting.any():
            np.testing.assert_allclose(poses[waiting, 2], previous_poses[waiting, 2],
                                       rtol=0, atol=1e-9)
            wait_travel += np.hypot(*(poses[waiting, :2] - previous_poses[waiting, :2]).T).sum()
            wait_steps += int(waiting.sum())
        # The cue never increases (monotone cleaning).
        if k % 31 == 0:
            if previous_cue is not None:
                assert np.all(world.cue <= previous_cue)
            previous_cue = world.cue.copy()
        previous_poses = poses.copy()
        previous_waiting = controllers.state == WAIT
    assert worst_overlap < 2e-3  # metres
    assert wait_steps > 500  # the run really exercised waiting
    # Pushes by others move waiting robots far less than driving would (8 cm/s).
    assert wait_travel < 0.02 * wait_steps * 0.08 * 0.032
    assert previous_cue.sum() < world.initial_cue.sum()


def test_same_seed_same_episode_other_seed_other():
    config = SwarmConfig().replace(episode={'population': 20, 'seed': 4, 'duration': 60.0})
    first, second = run_episode(config), run_episode(config)
    assert first.metrics == second.metrics
    assert np.array_equal(first.final_poses, second.final_poses)
    assert np.array_equal(first.final_cue, second.final_cue)
    other = run_episode(config.replace(episode={'seed': 5}))
    assert not np.array_equal(first.final_poses, other.final_poses)
    assert first.metrics != other.metrics


def test_metrics_rows_once_per_second():
    config = SwarmConfig().replace(episode={'population': 5, 'duration': 10.0})
    result = run_episode(config)
    assert [row['t'] for row in result.metrics] == [float(t) for t in range(11)]
    assert result.metrics[0]['mean_cue_fraction'] == 1.0
    assert 0.0 <= result.metrics[-1]['ratio_near_source'] <= 1.0


@pytest.mark.slow
def test_thirty_fast_robots_clean_well_below_the_start_in_4000_s():
    config = SwarmConfig().replace(episode={'population': 30, 'seed': 1},
                                   controller={'speed': 0.08})
    result = run_episode(config)
    assert result.metrics[-1]['t'] == 4000.0
    assert result.metrics[-1]['mean_cue_fraction'] < 0.25
    fractions = [row['mean_cue_fraction'] for row in result.metrics]
    assert all(b <= a for a, b in zip(fractions, fractions[1:]))


def test_without_robots_the_cue_stays_put():
    config = SwarmConfig().replace(episode={'population': 0, 'duration': 500.0})
    result = run_episode(config)
    assert {row['mean_cue_fraction'] for row in result.metrics} == {1.0}
    assert np.array_equal(result.final_cue, Episode(config).world.initial_cue)


def test_an_episode_without_snapshots_is_written(tmp_path):
    config = SwarmConfig().replace(episode={'population': 4, 'duration': 3.0, 'seed': 2})
    result = run_episode(config)
    assert not result.snapshots
    write_episode(result, tmp_path)
    with np.load(tmp_path / 'snapshots.npz') as saved:
        assert saved['cue'].shape == (0, *result.final_cue.shape)
        assert saved['poses'].shape == (0, 4, 3)
        np.testing.assert_array_equal(saved['final_poses'], result.final_poses)
    assert (tmp_path / 'episode.json').exists()


def test_cli_run_writes_the_outputs(tmp_path):
    out = tmp_path / 'episode'
    done = subprocess.run([sys.executable, '-m', 'swarm_supervisor.cli', 'run',
                           '--population', '6', '--speed', '4', '--seed', '3',
                           '--duration', '20', '--out', str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = (out / 'metrics.csv').read_text().splitlines()
    assert lines[0] == 't,mean_cue,mean_cue_fraction,ratio_near_source,coherency'
    assert len(lines) == 22
    import json
    record = json.loads((out / 'episode.json').read_text())
    assert record['seed'] == 3 and record['parameters']['controller']['speed'] == 0.04
    assert record['real_time_factor'] > 0
    assert (out / 'final_cue_map.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


@pytest.mark.parametrize('args, message', [
    (['--population', '-3'], 'episode.population = -3 is out of range'),
    (['--population', '0', '--speed', '-1'], 'out of range: allowed [0, 100]'),
    (['--population', '200000'], 'episode.population = 200000 is out of range'),
    (['--duration', 'long'], "invalid float value: 'long'"),
])
def test_cli_bad_arguments_exit_2_with_a_message(tmp_path, args, message):
    done = subprocess.run([sys.executable, '-m', 'swarm_supervisor.cli', 'run', '--out',
                           str(tmp_path / 'x'), *args], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 2
    assert message in done.stderr
    assert 'Traceback' not in done.stderr
    assert not (tmp_path / 'x').exists()
