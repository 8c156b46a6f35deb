"""The encounter model: which beams see another robot (the front five, a ring of eight), how
far a robot body is seen (a dark body), and how a robot tells a robot from a wall (by the
beam, or by its own place: near a wall anything it sees is a wall)."""

import math

import numpy as np
import pytest

from mona_controller.mona import SENSOR_MODEL, MonaParams
from swarm_world.params import WorldParams
from swarm_world.sensing.params import SensingParams
from swarm_world.world import World

RING = {'ir_count': 8, 'ir_span': 2 * math.pi * 7 / 8}  # every 45 degrees, none straight ahead


def world_of(fields: dict) -> World:
    """A world of Monas with ``fields`` (of the mona and the sensing sections)."""
    sensing = {key: value for key, value in fields.items() if key in SENSOR_MODEL}
    mona = {key: value for key, value in fields.items() if key not in SENSOR_MODEL}
    return World(WorldParams(), MonaParams(**mona), SensingParams(**sensing))


def seen(fields: dict, other: tuple[float, float], at=(1.4, 1.4)) -> tuple[bool, bool]:
    """(does any beam see something, does any say it is a robot) for a robot at ``at``
    facing +x and another at ``other`` (offset from it, m)."""
    world = world_of(fields)
    world.reset(np.array([[*at, 0.0], [at[0] + other[0], at[1] + other[1], 0.0]]), 1)
    ranges, is_robot = world.ir_readings()
    return bool((ranges[0] < np.inf).any()), bool(is_robot[0].any())


GAP = 0.09  # centre to centre: the bodies 1 cm apart


@pytest.mark.parametrize('layout, where, expected', [
    ({}, (GAP, 0.0), True),  # the front five see a robot in front
    ({}, (-GAP, 0.0), False),  # ... not one behind
    ({}, (0.0, GAP), True),  # ... and one beside, by the outer beam at 70 degrees
    (RING, (GAP, 0.0), True),  # a ring of eight sees it in front (by the beams at 22.5)
    (RING, (-GAP, 0.0), True),  # ... and behind
    (RING, (0.0, GAP), True),  # ... and beside
])
def test_which_beams_see_a_robot(layout, where, expected):
    assert seen(layout, where) == (expected, expected)


def test_a_dark_body_is_seen_only_near_contact():
    assert seen({}, (GAP, 0.0)) == (True, True)  # 1 cm: within the 3 cm range
    dark = {'ir_robot_factor': 0.2}  # seen within 0.6 cm
    assert seen(dark, (GAP, 0.0)) == (False, False)  # the beam it stops sees nothing
    assert seen(dark, (0.085, 0.0)) == (True, True)  # 0.5 cm
    # A wall is still seen at the whole range: robot 2 cm from the east wall, nobody near.
    world = world_of(dark)
    world.reset(np.array([[2.85 - 0.06, 1.4, 0.0]]), 1)
    ranges, is_robot = world.ir_readings()
    assert (ranges[0] < np.inf).any() and not is_robot[0].any()


def test_near_a_wall_a_robot_is_a_wall_only_in_the_position_mode():
    near_wall = (0.045, 1.4)  # centre 4.5 cm from the west wall, facing +x into the arena
    position = {'robot_detection': 'position'}  # wall_margin 5 cm
    assert seen({}, (GAP, 0.0), at=near_wall) == (True, True)  # the beam says robot
    assert seen(position, (GAP, 0.0), at=near_wall) == (True, False)  # its place says wall
    assert seen(position, (GAP, 0.0)) == (True, True)  # away from walls: a robot
    # And a wall it sees from beyond the margin is a robot to it: the rule's blind spot.
    world = world_of(position)
    world.reset(np.array([[2.85 - 0.06, 1.4, 0.0]]), 1)  # 6 cm from the east wall
    _, is_robot = world.ir_readings()
    assert is_robot[0].any()
