"""The message conversions of mona_controller.ros.messages and swarm_world.ros.world_messages
(message types only, no DDS)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from mona_controller.controllers.beeclust import STATES
from mona_controller.mona import MonaParams
from mona_controller.ros.messages import (
    fill_readings,
    ground_from_image,
    ground_image,
    ns_to_stamp,
    proximity_from_scan,
    proximity_scan,
    stamp_to_ns,
)
from swarm_world.params import WorldParams
from swarm_world.placement import place_robots, placement_rng
from swarm_world.ros.world_messages import (
    PoseArrayFiller,
    cue_from_image,
    cue_grid,
    cue_image,
    poses_from_pose_array,
    robot_markers,
)
from swarm_world.sensing.params import SensingParams
from swarm_world.world import World


@given(st.integers(0, 2**62))
def test_stamps_carry_integer_nanoseconds_exactly(ns):
    assert stamp_to_ns(ns_to_stamp(ns)) == ns


def test_readings_cross_the_messages_bit_for_bit():
    mona = MonaParams()
    world = World(WorldParams(), mona, SensingParams())
    world.reset(place_robots(60, 2.85, mona.body_radius, placement_rng(3)))
    readings = world.sense()
    assert np.isfinite(readings.ranges).any()  # some robots see something
    for i in range(60):
        image, scan = ground_image(i), proximity_scan(i, mona)
        fill_readings(image, scan, readings.ground[i], readings.ranges[i],
                      readings.is_robot[i], 123)
        ranges, is_robot, note = proximity_from_scan(scan, mona.ir_count)
        assert note == ''
        assert np.array_equal(ground_from_image(image), readings.ground[i])
        assert ranges.tobytes() == readings.ranges[i].tobytes()
        assert np.array_equal(is_robot, readings.is_robot[i])
        assert scan.header.frame_id == image.header.frame_id == f'mona_{i}/base_link'
    assert math.isclose(scan.angle_max - scan.angle_min, mona.ir_span)


def test_poses_round_trip_with_yaw_in_the_quaternion():
    poses = np.array([[0.1, 0.2, 0.0], [1.0, 2.0, math.pi / 2], [2.5, 0.3, -3.0]])
    filler = PoseArrayFiller()
    back = poses_from_pose_array(filler.fill(poses, 7))
    assert np.allclose(back, poses, atol=1e-12)
    assert len(filler.fill(poses[:1], 8).poses) == 1  # reused for a smaller swarm


def test_cue_image_has_the_top_row_first_and_the_grid_the_origin_first():
    cue = np.zeros((4, 3), dtype=np.float32)
    cue[3, 0] = 255.0  # the top-left cell (max y, min x)
    cue[0, 2] = 127.6  # the bottom-right cell
    image = cue_image(cue, 5)
    data = np.frombuffer(image.data, dtype=np.uint8).reshape(4, 3)
    assert data[0, 0] == 255 and data[3, 2] == 128
    assert np.array_equal(cue_from_image(image), data[::-1])
    grid = cue_grid(cue, 0.01, 5)
    assert (grid.info.width, grid.info.height, grid.info.resolution) == (3, 4, 0.01)
    cells = np.array(grid.data, dtype=np.int8).reshape(4, 3)
    assert cells[3, 0] == 100 and cells[0, 2] == 50 and cells.min() == 0


def test_markers_are_coloured_by_state_red_while_waiting():
    markers = robot_markers(np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0]]),
                            np.array([0, 2], dtype=np.uint8), 0.04, 5,
                            palette=[state.colour for state in STATES])
    colours = [(m.color.r, m.color.g) for m in markers.markers]
    assert colours[0][1] > colours[0][0] and colours[1][0] > colours[1][1]
    assert [m.id for m in markers.markers] == [0, 1]
