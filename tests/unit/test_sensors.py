"""Ground and IR sensors against hand-computed geometry, the reference and a marching oracle."""

import math

import numpy as np
import pytest

from mona_controller.mona import MonaParams
from swarm_world.arena import Arena, Disc, Polygon, Rect, pack
from swarm_world.params import WorldParams
from swarm_world.placement import place_robots
from swarm_world.reference import check_ir, first_difference, marched_ir
from swarm_world.sensing.ground import ground_readings
from swarm_world.sensing.headings import heading_trig
from swarm_world.sensing.ir import proximity, proximity_many
from swarm_world.sensing.params import SensingParams
from swarm_world.world import World

BEARINGS = MonaParams().ir_bearings()


def test_ground_sensors_sit_under_the_left_and_right_wheels():
    cue = np.tile(np.arange(100, dtype=np.float32), (100, 1))  # value = column (x cell)
    facing_north = np.array([[0.5, 0.5, math.pi / 2]])
    left, right = ground_readings(cue, 0.01, facing_north, MonaParams(), SensingParams())[0]
    assert (left, right) == (46, 53)  # left wheel at x = 0.465, right at x = 0.535
    facing_east = np.array([[0.5, 0.5, 0.0]])
    east = ground_readings(cue, 0.01, facing_east, MonaParams(), SensingParams())
    assert east[0].tolist() == [50, 50]


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


def crowded_scene(rng, arena, population=12):
    """A crowd in a small arena: robots near each other, the walls and the obstacles, touching
    at most."""
    return place_robots(population, arena.side, 0.04, rng, gap=0.0, obstacles=arena.obstacles)


SMALL = Arena(0.5)
CLUTTERED = Arena(0.5, (Disc('pillar', 0.32, 0.3, 0.05), Rect.of('wall', 0.1, 0.1, 0.2, 0.14),
                        Polygon('wedge', ((0.3, 0.42), (0.42, 0.44), (0.36, 0.48)))))


@pytest.mark.parametrize('arena', [SMALL, CLUTTERED], ids=['walls', 'obstacles'])
def test_ir_agrees_with_a_marching_oracle_on_crowded_scenes(arena):
    rng = np.random.default_rng(0)
    robots_seen = walls_seen = 0
    for _ in range(5):
        poses = crowded_scene(rng, arena)
        ranges, is_robot = check_ir(poses, 0.04, BEARINGS, 0.03, arena)  # = the reference
        expected, expected_robot = marched_ir(poses, 0.04, BEARINGS, 0.03, arena)
        seen = np.isfinite(expected)
        assert np.array_equal(np.isfinite(ranges), seen)
        np.testing.assert_allclose(ranges[seen], expected[seen], atol=2e-4)
        assert np.array_equal(is_robot, expected_robot)
        robots_seen += is_robot.sum()
        walls_seen += (seen & ~is_robot).sum()
    assert robots_seen > 5 and walls_seen > 5  # the scenes exercised both kinds of obstacle


def test_ir_sees_each_kind_of_obstacle_as_a_wall():
    pillar = Disc('pillar', 1.0, 1.0, 0.1)
    box = Rect.of('box', 1.5, 0.5, 1.7, 0.9)
    wedge = Polygon('wedge', ((0.5, 2.0), (0.7, 2.0), (0.6, 2.3)))
    arena = Arena(2.85, (pillar, box, wedge))
    poses = np.array([[1.0 - 0.16, 1.0, 0.0],  # 2 cm from the pillar, facing it
                      [1.5 - 0.05, 0.7, 0.0],  # 1 cm from the box's west face
                      [0.6, 2.0 - 0.065, math.pi / 2]])  # 2.5 cm below the wedge's base
    ranges, is_robot = check_ir(poses, 0.04, BEARINGS, 0.03, arena)
    assert ranges[0, 2] == pytest.approx(0.02, abs=1e-6)
    assert ranges[1, 2] == pytest.approx(0.01, abs=1e-6)
    assert ranges[2, 2] == pytest.approx(0.025, abs=1e-6)
    assert not is_robot.any()
    assert np.isinf(ranges[0, 0]) and np.isinf(ranges[0, 4])  # the side beams miss the pillar
    bare = proximity(poses, 0.04, BEARINGS, 0.03, 2.85)
    assert np.isinf(bare[0]).all()  # without the obstacles nothing is in range


def test_ir_nearest_hit_wins_among_robots_walls_and_obstacles():
    pillar = Disc('pillar', 1.2, 1.0, 0.05)
    arena = Arena(2.85, (pillar,))
    near_robot = np.array([[1.0, 1.0, 0.0], [1.1, 1.0, 0.0]])  # robot 2 cm, pillar 11 cm ahead
    ranges, is_robot = check_ir(near_robot, 0.04, BEARINGS, 0.03, arena)
    assert ranges[0, 2] == pytest.approx(0.02, abs=1e-6) and is_robot[0, 2]
    near_pillar = np.array([[1.09, 1.0, 0.0], [1.09, 1.0 - 0.1, 0.0]])
    ranges, is_robot = check_ir(near_pillar, 0.04, BEARINGS, 0.03, arena)
    assert ranges[0, 2] == pytest.approx(0.02, abs=1e-6) and not is_robot[0, 2]
    # A tie, both at range 0 (a centre inside the pillar and inside another robot: never
    # in an episode, but the rule is exact): it goes to the pillar, as a tie with a wall.
    tie = np.array([[1.2, 1.0, 0.0], [1.21, 1.0, 0.0]])
    ranges, is_robot = check_ir(tie, 0.04, BEARINGS, 0.03, arena)
    assert ranges[0, 2] == 0.0 and not is_robot[0, 2]
    ranges, is_robot = proximity(tie, 0.04, BEARINGS, 0.03, 2.85)
    assert ranges[0, 2] == 0.0 and is_robot[0, 2]  # without the pillar: the robot


#: Headings beyond pi as pymunk leaves them (they grow without bound), on both sides of the
#: kernel's |heading| >= 1e4 branch, where every beam's direction is worked out exactly.
HEADINGS = (0.3, -2.0 * math.pi - 0.3, 40.0 * math.pi + 1.0, 9999.9, -9999.9, 1e4, 1e5, -3e6,
            7.5e8)


@pytest.mark.parametrize('arena', [SMALL, CLUTTERED], ids=['walls', 'obstacles'])
def test_ir_with_headings_far_beyond_pi_equals_the_reference(arena):
    rng = np.random.default_rng(3)
    for heading in HEADINGS:
        poses = crowded_scene(rng, arena, 14)
        poses[:, 2] += heading
        ranges, is_robot = check_ir(poses, 0.04, BEARINGS, 0.03, arena)
        assert np.isfinite(ranges).any()
        # A turn by 2 pi is the same robot up to the rounding of the angle sum: the ranges
        # move by far less than a micrometre.
        turned, _ = proximity(poses - [0, 0, 2 * math.pi], 0.04, BEARINGS, 0.03, arena.side,
                              arena.packed)
        assert np.array_equal(np.isfinite(turned), np.isfinite(ranges))
        seen = np.isfinite(ranges) & np.isfinite(turned)
        np.testing.assert_allclose(turned[seen], ranges[seen], atol=1e-6)


def test_ir_on_grazing_beams_equals_the_reference():
    b = 1  # heading -BEARINGS[b] points beam b exactly along +x (sin 0 = 0)
    along_x = -float(BEARINGS[b])
    slope = math.atan2(0.2, 0.4)  # the direction of the wedge's lower edge
    pillar = Disc('pillar', 1.5, 1.5, 0.02)  # small enough for a tangent within reach
    box = Rect.of('box', 2.0, 0.5, 2.3, 0.8)
    wedge = Polygon('wedge', ((0.5, 2.0), (0.9, 2.2), (0.5, 2.4)))
    arena = Arena(2.85, (pillar, box, wedge))
    poses = np.array([
        [1.44, 1.48, along_x],  # the beam tangent to the pillar's bottom, 6 cm on
        [1.44, 1.52, along_x],  # tangent to its top
        [1.44, np.nextafter(1.48, 2.0), along_x],  # a hair inside the tangent
        [1.95, 0.5, along_x],  # along the box's bottom edge, onto its corner
        [1.95, 0.8, along_x],  # along its top edge
        [1.95, 0.65, along_x],  # square on its west face
        [1.0, 0.05, along_x],  # along the south wall, 5 cm from it
        [1.0, 2.85 - 0.06, along_x],  # along the north wall
        [0.5, 1.95, math.pi / 2 - float(BEARINGS[b])],  # up the wedge's west edge
        [0.5 - 0.05 * math.cos(slope), 2.0 - 0.05 * math.sin(slope),
         slope - float(BEARINGS[b])],  # along its lower edge, onto its corner
    ])
    assert all(arena.clearance(x, y) >= 0.04 - 1e-12 for x, y, _ in poses)
    # Each robot alone (some stand on top of each other), with and without the obstacles,
    # and turned far beyond pi, past the kernel's 1e4 branch.
    for obstacles in ((), arena.obstacles):
        for turn in (0.0, 1e5, -3e6):
            for pose in poses + [0, 0, turn]:
                check_ir(pose[None], 0.04, BEARINGS, 0.03, Arena(2.85, obstacles))
    ranges, is_robot = (np.concatenate(readings) for readings in zip(
        *(check_ir(pose[None], 0.04, BEARINGS, 0.03, arena) for pose in poses)))
    # Rounding decides whether a tangent beam touches, and whether a beam along a slanted
    # edge (its direction a rounded angle) meets the corner: either way, the reference's.
    for grazing, expected in zip(ranges[[0, 1, 8, 9], b], (0.02, 0.02, 0.01, 0.01)):
        assert np.isinf(grazing) or grazing == pytest.approx(expected, abs=1e-6)
    assert ranges[2, b] == pytest.approx(0.02, abs=1e-6)  # a hair inside the tangent hits
    # Along an axis-aligned edge the direction is exact: the edge across meets it at its end.
    np.testing.assert_allclose(ranges[3:6, b], 0.01, atol=1e-6)
    assert np.isinf(ranges[6:8, b]).all()  # a beam along a wall sees none of it
    assert not is_robot.any()


def test_batched_ir_takes_each_arenas_own_obstacles():
    rng = np.random.default_rng(11)
    arenas = [CLUTTERED, SMALL, Arena(0.5, (Disc('post', 0.25, 0.25, 0.1),)), CLUTTERED]
    scenes = [crowded_scene(rng, arena, n) for arena, n in zip(arenas, (12, 10, 0, 14))]
    poses = np.concatenate(scenes)
    bounds = np.cumsum([0] + [len(scene) for scene in scenes]).astype(np.int64)
    count = len(arenas)
    many = proximity_many(poses, heading_trig(poses), bounds, np.full(count, 0.04),
                          np.tile(BEARINGS, (count, 1)), np.full(count, 0.03),
                          np.full(count, 0.5), pack(arenas))
    for arena, scene, lo, hi in zip(arenas, scenes, bounds[:-1], bounds[1:]):
        alone = check_ir(scene, 0.04, BEARINGS, 0.03, arena)
        assert np.array_equal(many[0][lo:hi], alone[0])
        assert np.array_equal(many[1][lo:hi], alone[1])
    # None: no arena has obstacles, as a batch of bare arenas packs it.
    bare = proximity_many(poses, heading_trig(poses), bounds, np.full(count, 0.04),
                          np.tile(BEARINGS, (count, 1)), np.full(count, 0.03),
                          np.full(count, 0.5))
    packed = proximity_many(poses, heading_trig(poses), bounds, np.full(count, 0.04),
                            np.tile(BEARINGS, (count, 1)), np.full(count, 0.03),
                            np.full(count, 0.5), pack([SMALL] * count))
    assert np.array_equal(bare[0], packed[0]) and np.array_equal(bare[1], packed[1])
    assert np.array_equal(bare[0][:12], proximity(scenes[0], 0.04, BEARINGS, 0.03, 0.5)[0])


def test_check_ir_names_the_first_difference():
    poses = np.array([[1.0, 1.0, 0.0], [1.1, 1.0, 0.0]])
    ranges, _ = proximity(poses, 0.04, BEARINGS, 0.03, 2.85)
    moved = ranges.copy()
    moved[0, 2] = np.nextafter(moved[0, 2], np.float32(1.0))
    with pytest.raises(AssertionError, match=r'IR ranges differ first at robot 0, beam 2: '):
        first_difference('IR ranges', moved, ranges, ('robot', 'beam'))
    first_difference('IR ranges', ranges, ranges.copy(), ('robot', 'beam'))


def test_world_cue_is_the_papers_disc():
    world = World(WorldParams(), MonaParams(), SensingParams())
    assert world.cue.shape == (285, 285)
    assert world.cue.max() == pytest.approx(255.0, abs=1.0)
    assert world.cue[0, 0] == 0.0
    # Linear fall-off: half way to the rim is half the peak.
    row = 142
    col = 142 + round(2.227 / 4 / 0.01)
    assert world.cue[row, col] == pytest.approx(127.5, abs=2.0)
