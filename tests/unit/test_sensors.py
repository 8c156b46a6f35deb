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


def marched_ranges(poses, bearings, radius=0.04, ir_range=0.03, side=2.85, step=1e-4):
    """An independent oracle: walk along every beam in 0.1 mm steps until it hits something."""
    ranges = np.full((len(poses), len(bearings)), np.inf)
    is_robot = np.zeros(ranges.shape, dtype=bool)
    for i, (x, y, heading) in enumerate(poses):
        others = np.delete(poses[:, :2], i, axis=0)
        for b, bearing in enumerate(bearings):
            for t in np.arange(radius, radius + ir_range + step, step):
                px, py = x + t * math.cos(heading + bearing), y + t * math.sin(heading + bearing)
                if np.any(np.hypot(others[:, 0] - px, others[:, 1] - py) <= radius):
                    ranges[i, b], is_robot[i, b] = t - radius, True
                    break
                if not (0 <= px <= side and 0 <= py <= side):
                    ranges[i, b] = t - radius
                    break
    return ranges, is_robot


def test_ir_agrees_with_a_marching_oracle_on_crowded_scenes():
    from swarm_world.placement import place_robots
    rng = np.random.default_rng(0)
    robots_seen = walls_seen = 0
    for _ in range(5):
        # A crowd in a small arena: robots near each other and near the walls, touching at most.
        poses = place_robots(12, 0.5, 0.04, rng, gap=0.0)
        ranges, is_robot = proximity(poses, 0.04, BEARINGS, 0.03, 0.5)
        expected, expected_robot = marched_ranges(poses, BEARINGS, side=0.5)
        seen = np.isfinite(expected)
        assert np.array_equal(np.isfinite(ranges), seen)
        np.testing.assert_allclose(ranges[seen], expected[seen], atol=2e-4)
        assert np.array_equal(is_robot, expected_robot)
        robots_seen += is_robot.sum()
        walls_seen += (seen & ~is_robot).sum()
    assert robots_seen > 5 and walls_seen > 5  # the scenes exercised both kinds of obstacle


def test_world_cue_is_the_papers_disc():
    world = World(WorldParams(), MonaParams())
    assert world.cue.shape == (285, 285)
    assert world.cue.max() == pytest.approx(255.0, abs=1.0)
    assert world.cue[0, 0] == 0.0
    # Linear fall-off: half way to the rim is half the peak.
    row = 142
    col = 142 + round(2.227 / 4 / 0.01)
    assert world.cue[row, col] == pytest.approx(127.5, abs=2.0)
