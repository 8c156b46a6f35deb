"""Ground and IR sensors against hand-computed geometry."""

import math

import numpy as np
import pytest

from mona_controller.mona import MonaParams
from swarm_world.params import WorldParams
from swarm_world.sensors import ground_readings, proximity
from swarm_world.world import World

BEARINGS = MonaParams().ir_bearings()


def test_ground_sensors_sit_under_the_left_and_right_wheels():
    cue = np.tile(np.arange(100, dtype=np.float32), (100, 1))  # value = column (x cell)
    facing_north = np.array([[0.5, 0.5, math.pi / 2]])
    left, right = ground_readings(cue, 0.01, facing_north, 0.07)[0]
    assert (left, right) == (46, 53)  # left wheel at x = 0.465, right at x = 0.535
    facing_east = np.array([[0.5, 0.5, 0.0]])
    assert ground_readings(cue, 0.01, facing_east, 0.07)[0].tolist() == [50, 50]


def test_ir_sees_a_robot_ahead_and_marks_it():
    poses = np.array([[1.0, 1.0, 0.0], [1.1, 1.0, 0.0]])  # 2 cm gap between the bodies
    ranges, is_robot = proximity(poses, 0.04, BEARINGS, 0.03, 2.85)
    assert ranges[0, 2] == pytest.approx(0.02, abs=1e-6)  # the centre beam
    assert is_robot[0, 2]
    assert np.isinf(ranges[1]).all()  # the other one faces away
    assert not is_robot[1].any()


def test_ir_sees_a_wall_and_marks_it_not_a_robot():
    poses = np.array([[2.85 - 0.06, 1.0, 0.0]])  # 2 cm from the east wall, facing it
    ranges, is_robot = proximity(poses, 0.04, BEARINGS, 0.03, 2.85)
    assert ranges[0, 2] == pytest.approx(0.02, abs=1e-6)
    assert not is_robot.any()
    assert np.isinf(ranges[0, 0])  # the outermost beam at -70 deg does not reach


def test_ir_out_of_range_is_inf():
    poses = np.array([[1.0, 1.0, 0.0], [1.2, 1.0, 0.0]])
    ranges, _ = proximity(poses, 0.04, BEARINGS, 0.03, 2.85)
    assert np.isinf(ranges).all()


def test_physics_broadphase_finds_what_brute_force_finds():
    """The world's pymunk sensor rings give the same readings as the all-pairs cast."""
    from swarm_supervisor.config import SwarmConfig
    from swarm_supervisor.runner import start_episode
    from mona_controller.mona import wheels_to_twist
    config = SwarmConfig().replace(episode={'population': 40, 'seed': 5})
    world, controllers = start_episode(config)
    for _ in range(600):
        readings = world.sense()
        brute = proximity(world.poses, 0.04, world.bearings, 0.03, 2.85)
        np.testing.assert_array_equal(readings.ranges, brute[0])
        np.testing.assert_array_equal(readings.is_robot, brute[1])
        command = controllers.step(readings.ground, readings.ranges, readings.is_robot,
                                   readings.now)
        world.step(*wheels_to_twist(command.wheels, config.mona), command.cleaner)
    assert controllers.encounters.sum() > 0  # the check covered robots seeing robots


def test_world_cue_is_the_papers_disc():
    world = World(WorldParams(), MonaParams())
    assert world.cue.shape == (285, 285)
    assert world.cue.max() == pytest.approx(255.0, abs=1.0)
    assert world.cue[0, 0] == 0.0
    # Linear fall-off: half way to the rim is half the peak.
    row = 142
    col = 142 + round(2.227 / 4 / 0.01)
    assert world.cue[row, col] == pytest.approx(127.5, abs=2.0)
