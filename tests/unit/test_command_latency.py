"""The command latency (``sensing.command_latency``): a command drives the wheels and the cleaner
L control steps after the readings it answers; 0 is the engine as it was, and a robot's delay
is its own in any batch."""

import numpy as np
import pytest

from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine import run_batch, run_episode
from swarm_world.params import WorldParams
from swarm_world.sensing.delay import CommandDelay
from swarm_world.sensing.params import SensingParams
from swarm_world.world import World

POSES = np.array([[0.5, 0.5, 0.0], [2.0, 2.0, 1.5], [1.4, 1.4, -2.0]])


def commands(steps: int, population: int) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """A different command for every robot and step (seeded), cleaner on now and then."""
    rng = np.random.default_rng(5)
    return [(rng.uniform(0.0, 0.1, population), rng.uniform(-1.0, 1.0, population),
             rng.random(population) < 0.3) for _ in range(steps)]


def drive(world: World, sequence) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Poses after each step and the cleaner state each step applied."""
    world.reset(POSES, seed=3)
    poses, cleaning = [], []
    for linear, angular, cleaner in sequence:
        world.step(linear, angular, cleaner)
        poses.append(world.poses.copy())
        cleaning.append(world.cleaning.copy())
    return poses, cleaning


@pytest.mark.parametrize('latency, control_steps', [(1, 1), (3, 1), (2, 3)])
def test_a_command_drives_the_wheels_latency_control_steps_later(latency, control_steps):
    params = WorldParams(control_steps=control_steps)
    delayed = World(params, MonaParams(), SensingParams(command_latency=latency, wheel_noise=0.05))
    # The same noise draws, step by step.
    at_once = World(params, MonaParams(), SensingParams(wheel_noise=0.05))
    sequence = commands(40, len(POSES))
    lag = latency * control_steps
    stop = (np.zeros(len(POSES)), np.zeros(len(POSES)), np.zeros(len(POSES), dtype=bool))
    shifted = [stop] * lag + sequence[:-lag]
    poses, cleaning = drive(delayed, sequence)
    expected_poses, expected_cleaning = drive(at_once, shifted)
    for step in range(len(sequence)):
        assert np.array_equal(poses[step], expected_poses[step]), step
        assert np.array_equal(cleaning[step], expected_cleaning[step]), step
    # Until the first command arrives the robots stand still, cleaner off.
    assert np.array_equal(poses[lag - 1], POSES) and not np.any(cleaning[:lag])
    assert not np.array_equal(poses[-1], drive(at_once, sequence)[0][-1])


def test_a_reset_empties_the_delay_line():
    world = World(WorldParams(), MonaParams(), SensingParams(command_latency=2))
    sequence = commands(5, len(POSES))
    first = drive(world, sequence)[0]
    again = drive(world, sequence)[0]  # drive() resets: nothing of the first episode is left
    assert all(np.array_equal(a, b) for a, b in zip(first, again))


def test_the_delay_line_refuses_zero_steps_and_the_schema_a_negative_latency():
    with pytest.raises(ValueError, match='0 steps'):
        CommandDelay(0, 3)
    with pytest.raises(ParameterError, match='sensing.command_latency'):
        SensingParams(command_latency=-1)


def config(latency: int, **episode) -> SwarmConfig:
    return SwarmConfig().replace(
        episode={'population': 12, 'seed': 4, 'duration': 30.0, **episode},
        sensing={'command_latency': latency})


def test_latency_changes_the_episode_and_zero_is_the_engine_as_it_was():
    # The golden digests pin latency 0 byte for byte; here 0 equals the default config.
    zero, three = run_episode(config(0)), run_episode(config(3))
    default = run_episode(SwarmConfig().replace(episode={'population': 12, 'seed': 4,
                                                         'duration': 30.0}))
    assert zero.metrics == default.metrics
    assert np.array_equal(zero.final_poses, default.final_poses)
    assert not np.array_equal(zero.final_poses, three.final_poses)


def test_each_robots_delay_is_its_own_in_a_batch():
    """Episodes of different latencies (and none) batched together equal each one alone."""
    configs = [config(3), config(0, population=5, seed=9), config(5, population=20, seed=2),
               config(1, population=7, seed=3, duration=21.0)]
    times = (0.0, 10.0, 21.0)
    alone = [run_episode(c, snapshot_times=times) for c in configs]
    for order in ([0, 1, 2, 3], [3, 2, 1, 0]):
        batched = run_batch([configs[k] for k in order], snapshot_times=times)
        for member, k in zip(batched, order):
            lone = alone[k]
            assert member.metrics == lone.metrics, k
            assert member.encounters == lone.encounters, k
            assert np.array_equal(member.final_poses, lone.final_poses), k
            assert np.array_equal(member.final_cue, lone.final_cue), k
    assert sum(r.encounters for r in alone) > 0
