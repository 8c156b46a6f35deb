"""Sensor and wheel noise: counter-based streams, their statistics, quantisation, and the
noise-free model kept bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from mona_controller.mona import MonaParams
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.runner import run_episode
from swarm_world.params import WorldParams
from swarm_world.sensing import noise
from swarm_world.sensing.ground import ground_readings
from swarm_world.sensing.params import SensingParams
from swarm_world.world import World


def test_a_robots_stream_does_not_depend_on_the_others():
    alone = noise.uniforms(7, noise.GROUND_STREAM, np.array([5]), 12, 3)
    among = noise.uniforms(7, noise.GROUND_STREAM, np.array([9, 5, 0]), 12, 3)
    np.testing.assert_array_equal(alone[0], among[1])
    # Every key part matters: seed, stream, robot, step.
    for args in ((8, noise.GROUND_STREAM, [5], 12), (7, noise.IR_STREAM, [5], 12),
                 (7, noise.GROUND_STREAM, [6], 12), (7, noise.GROUND_STREAM, [5], 13)):
        assert not np.array_equal(noise.uniforms(args[0], args[1], np.array(args[2]),
                                                 args[3], 3)[0], alone[0]), args


def test_uniforms_and_normals_have_their_distribution():
    robots = np.arange(200)
    u = np.concatenate([noise.uniforms(3, 2, robots, step, 5).ravel() for step in range(50)])
    assert u.min() >= 0.0 and u.max() < 1.0
    assert abs(u.mean() - 0.5) < 0.01 and abs(u.std() - np.sqrt(1 / 12)) < 0.01
    z = np.concatenate([noise.normals(3, 2, robots, step, 5).ravel() for step in range(50)])
    assert abs(z.mean()) < 0.02 and abs(z.std() - 1.0) < 0.02
    assert abs(np.mean(np.abs(z) < 1.0) - 0.6827) < 0.01


def test_ground_noise_is_added_before_quantisation_and_clipped():
    cue = np.full((10, 10), 100.4, dtype=np.float32)
    cue[:5, :] = 1.0
    poses = np.array([[0.075, 0.05, 0.0]] * 4)  # left sensor (y + 3.5 cm) on 100.4, right 1.0
    extra = np.array([[0.0, 0.0], [0.2, -3.0], [-200.0, 0.4], [300.0, 254.4]])
    readings = ground_readings(cue, 0.01, poses, MonaParams(), SensingParams(), extra)
    assert readings.dtype == np.uint8
    np.testing.assert_array_equal(ground_readings(cue, 0.01, poses, MonaParams(), SensingParams()),
                                  [[100, 1]] * 4)
    np.testing.assert_array_equal(readings, [[100, 1], [101, 0], [0, 1], [255, 255]])


def test_ground_noise_statistics_match_the_parameter():
    sigma = 6.0
    world = World(WorldParams(), MonaParams(), SensingParams(ground_noise=sigma))
    clean = World(WorldParams(), MonaParams(), SensingParams())
    poses = np.array([[1.2, 1.3, 0.4], [0.6, 2.0, -1.0]])
    world.reset(poses, seed=11)
    clean.reset(poses, seed=11)
    truth = clean.sense().ground.astype(float)
    samples = []
    for _ in range(1500):
        samples.append(world.sense().ground.astype(float))
        world.step(np.zeros(2), np.zeros(2), np.zeros(2, dtype=bool))
    samples = np.array(samples)
    assert np.all(samples == np.round(samples))
    error = samples - truth
    assert np.all(np.abs(error.mean(axis=0)) < 0.6)
    assert np.all(np.abs(error.std(axis=0) - sigma) < 0.5)


def test_ir_misses_at_their_rate_and_wheels_slip_by_theirs():
    world = World(WorldParams(), MonaParams(), SensingParams(ir_miss=0.25))
    poses = np.array([[1.0, 1.0, 0.0], [1.09, 1.0, np.pi]])  # face to face, 1 cm apart
    world.reset(poses, seed=2)
    seen = []
    for _ in range(800):
        seen.append(np.isfinite(world.sense().ranges[:, 2]))
        world.step(np.zeros(2), np.zeros(2), np.zeros(2, dtype=bool))
    assert abs(1 - np.mean(seen) - 0.25) < 0.03
    linear, angular = noise.noisy_wheels(np.array([0.08]), np.array([0.0]), 0.07,
                                         np.array([[0.0, 0.0]]))
    assert linear[0] == 0.08 and angular[0] == 0.0
    linear, angular = noise.noisy_wheels(np.array([0.08]), np.array([0.0]), 0.07,
                                         np.array([[0.1, -0.1]]))
    assert linear[0] == pytest.approx(0.08) and angular[0] == pytest.approx(-0.016 / 0.07)


def test_noise_levels_are_reproducible_and_zero_is_the_noise_free_model():
    base = SwarmConfig().replace(episode={'population': 10, 'duration': 30.0, 'seed': 4})
    noisy = base.replace(sensing={'ground_noise': 8.0, 'ir_miss': 0.1, 'wheel_noise': 0.05})
    first, second = run_episode(noisy), run_episode(noisy)
    np.testing.assert_array_equal(first.final_poses, second.final_poses)
    np.testing.assert_array_equal(first.final_cue, second.final_cue)
    plain = run_episode(base)
    zero = run_episode(base.replace(sensing={'ground_noise': 0.0, 'ir_miss': 0.0,
                                             'wheel_noise': 0.0}))
    np.testing.assert_array_equal(plain.final_poses, zero.final_poses)
    assert not np.array_equal(first.final_poses, plain.final_poses)
    other = run_episode(noisy.replace(episode={'seed': 5}))
    assert not np.array_equal(other.final_poses, first.final_poses)
