"""The episode engine against the step written out longhand, and the sim-time helpers."""

import math

import numpy as np
import pytest

from mona_controller.controllers.beeclust import SwarmController
from mona_controller.mona import wheels_to_twist
from swarm_metrics.metrics import sample
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import PARTS, Episode, place_swarm
from swarm_supervisor.engine.runner import run_episode
from swarm_world.placement import place_robots, placement_rng
from swarm_world.timing import crossed, steps_for
from swarm_world.world import World

# 0.7 s samples are not a multiple of the 32 ms step, 20.01 s not a multiple of either; 30
# robots meet often enough that waits end and the controllers draw random turns.
CONFIG = SwarmConfig().replace(episode={'population': 30, 'seed': 9, 'duration': 20.01},
                               metrics={'sample_period': 0.7})


def longhand(config):
    """The episode as the runner stepped it before the engine: (poses per step, rows, cue)."""
    n, seed = config.episode.population, config.episode.seed
    world = World(config.world, config.mona)
    world.reset(place_robots(n, config.world.arena_side, config.mona.body_radius,
                             placement_rng(seed)))
    controllers = SwarmController(config.controller, config.mona, range(n))
    controllers.reset(seed)
    sample_ns = round(config.metrics.sample_period * 1e9)

    def row(t):
        return sample(t, world.cue, world.initial_mean_cue, world.poses[:, :2],
                      config.world.centre, config.metrics)

    trajectory, rows = [], [row(0.0)]
    for _ in range(math.ceil(config.episode.duration / config.world.step_period)):
        readings = world.sense()
        command = controllers.step(readings.ground, readings.ranges, readings.is_robot,
                                   readings.now)
        before = world.time_ns
        world.step(*wheels_to_twist(command.wheels, config.mona), command.cleaner)
        trajectory.append(world.poses.copy())
        if world.time_ns // sample_ns > before // sample_ns:
            rows.append(row(world.time_ns // sample_ns * config.metrics.sample_period))
    return trajectory, rows, world.cue.copy()


def drive(episode):
    """Step ``episode`` to its end: (poses per step, rows, final cue)."""
    trajectory, rows = [], [episode.metrics()]
    while not episode.done:
        step = episode.step()
        trajectory.append(episode.world.poses.copy())
        if step.sampled:
            rows.append(episode.metrics())
    return trajectory, rows, episode.world.cue.copy()


def assert_same_run(first, second):
    assert len(first[0]) == len(second[0])
    for a, b in zip(first[0], second[0]):
        assert np.array_equal(a, b)
    assert first[1] == second[1]
    assert np.array_equal(first[2], second[2])


@pytest.fixture(scope='module')
def reference():
    return longhand(CONFIG)


def test_the_engine_steps_exactly_as_the_longhand_loop(reference):
    assert_same_run(drive(Episode(CONFIG)), reference)
    assert len(reference[1]) == 29  # t = 0, 0.7, ... 19.6 s
    assert not np.array_equal(reference[2], Episode(CONFIG).world.initial_cue)  # it cleaned


def test_run_episode_is_the_engine(reference):
    result = run_episode(CONFIG)
    assert result.metrics == reference[1]
    assert np.array_equal(result.final_poses, reference[0][-1])
    assert np.array_equal(result.final_cue, reference[2])
    assert np.array_equal(result.initial_poses, place_swarm(CONFIG, 9))
    assert result.steps == len(reference[0]) == CONFIG.steps() == 626


def test_the_profiled_step_is_the_same_step(reference):
    episode = Episode(CONFIG, profile=True)
    assert_same_run(drive(episode), reference)
    assert set(episode.profile) == set(PARTS)
    assert all(seconds > 0 for seconds in episode.profile.values())


def test_the_profiled_step_senses_as_the_real_step_with_footprint_noise_and_obstacles():
    # Every sensing path: the footprint's sensed field, the three noise streams, obstacles
    # seen by the IR, and a control period.
    config = CONFIG.replace(mona={'ground_footprint': 0.03, 'ground_noise': 5.0,
                                  'ir_miss': 0.2, 'wheel_noise': 0.05},
                            world={'obstacles': {'pillar': [1.2, 1.2, 0.15]},
                                   'control_steps': 2})
    assert_same_run(drive(Episode(config, profile=True)), drive(Episode(config)))


def test_reset_with_a_seed_replays_that_seed():
    episode = Episode(CONFIG)
    first = drive(episode)
    episode.reset(3)
    assert episode.steps_done == 0 and episode.time_ns == 0 and not episode.done
    other = drive(episode)
    episode.reset(3)
    assert_same_run(drive(episode), other)
    assert not np.array_equal(other[0][-1], first[0][-1])
    episode.reset()  # back to the config's seed
    assert episode.seed == 9
    assert_same_run(drive(episode), first)
    assert_same_run(drive(Episode(CONFIG.replace(episode={'seed': 3}))), other)


def test_step_reports_times_and_samples():
    config = CONFIG.replace(episode={'duration': 1.0}, metrics={'sample_period': 0.1})
    episode = Episode(config)
    assert episode.steps_total == 32 and episode.initial_poses.shape == (30, 3)
    steps = []
    while not episode.done:
        steps.append(episode.step())
    assert [s.before_ns for s in steps] == [k * 32_000_000 for k in range(32)]
    assert [s.time_ns for s in steps] == [k * 32_000_000 for k in range(1, 33)]
    assert episode.time_ns == 1_024_000_000 and episode.now == 1.024
    # boundaries at 0.1 s, 0.2 s, ... 1.0 s: each seen once, at the first step reaching it
    assert [s.time_ns for s in steps if s.sampled][:3] == [128_000_000, 224_000_000,
                                                         320_000_000]
    assert sum(s.sampled for s in steps) == 10
    assert all(len(s.command.wheels) == 30 for s in steps)


def test_step_reports_who_cleaned_on_each_cleaning_tick():
    episode = Episode(CONFIG)
    ticks = 0
    while not episode.done:
        step = episode.step()
        if crossed(step.before_ns, step.time_ns, 1_000_000_000):  # world.cleaning_period
            assert np.array_equal(step.cleaned, np.flatnonzero(step.command.cleaner))
            ticks += len(step.cleaned) > 0
        else:
            assert len(step.cleaned) == 0
    assert ticks >= 3


def test_crossed_counts_each_boundary_once():
    assert crossed(0, 1000, 1000) and crossed(999, 1000, 1000)
    assert not crossed(1000, 1999, 1000) and not crossed(1000, 1000, 1000)
    assert crossed(0, 5000, 1000)  # several boundaries in one step: once
    assert crossed(-1, 0, 1000) and not crossed(-1000, -1, 1000)  # times before a start
    assert crossed(5, 5, 0) and crossed(0, 1, 0)  # period 0: every step
    step, period = 32_000_000, 1_000_000_000
    assert sum(crossed(k * step, (k + 1) * step, period) for k in range(313)) == 10


def test_steps_for_rounds_the_duration_up_to_whole_steps():
    assert steps_for(0.064, 32_000_000) == 2  # an exact multiple
    assert steps_for(0.065, 32_000_000) == 3
    assert steps_for(1.0, 32_000_000) == 32
    assert steps_for(4000.0, 32_000_000) == 125_000
    assert steps_for(1e-9, 32_000_000) == 1
    assert steps_for(0.0, 32_000_000) == 0
    assert steps_for(0.07, 10_000_000) == 7  # 0.07 / 0.01 is 7.000000000000001 in floats
    assert steps_for(1e7, 1_000_000) == 10**10
    config = SwarmConfig().replace(episode={'duration': 0.07}, world={'step_period': 0.01})
    assert config.steps() == 7
