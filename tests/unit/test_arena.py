"""The arena seam: obstacles parsed from world.obstacles (refused with the key named), the cue
under them, and episodes among them: no robot enters one, the IR sees them as walls,
placement avoids them, a batch of mixed layouts equals each episode alone."""

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError
from swarm_supervisor.config import SwarmConfig, load_config
from swarm_supervisor.engine.batch import Batch
from swarm_supervisor.engine.episode import Episode
from swarm_supervisor.engine.runner import run_batch, run_episode
from swarm_world.arena import Arena, Disc, Polygon, Rect, pack
from swarm_world.field import CueField, initial_cue
from swarm_world.params import WorldParams
from swarm_world.reference import check_ir, check_placement
from swarm_world.sensing.ir import proximity
from swarm_world.sensing.params import SensingParams

#: A few of each kind in the paper's arena, none over the paper's source at the centre.
LAYOUT = {'pillar': ['disc', 0.9, 2.0, 0.15],
          'wall': ['rect', 1.8, 0.5, 1.9, 1.3],
          'wedge': ['polygon', 0.4, 0.4, 0.9, 0.5, 0.6, 0.9]}


def test_obstacles_are_parsed_in_name_order():
    arena = WorldParams(obstacles=LAYOUT).arena()
    assert [obstacle.name for obstacle in arena.obstacles] == ['pillar', 'wall', 'wedge']
    pillar, wall, wedge = arena.obstacles
    assert pillar == Disc('pillar', 0.9, 2.0, 0.15)
    assert wall == Rect.of('wall', 1.8, 0.5, 1.9, 1.3) and wall.kind == 'rect'
    assert isinstance(wedge, Polygon) and wedge.kind == 'polygon'
    assert wedge.area == pytest.approx(0.115)  # positive: counter-clockwise


def test_no_obstacles_by_default():
    arena = WorldParams().arena()
    assert arena == Arena(2.85) and arena.obstacles == ()
    assert [shape.kind for shape in arena.shapes] == ['walls']
    packed = arena.packed
    assert packed.boxes.shape == (0, 4) and packed.bounds.tolist() == [0, 0]


def test_the_kind_may_be_left_out_for_ros_parameter_files():
    # rcl refuses a list that mixes strings and numbers, so a file both runners read
    # gives the numbers alone: 3 are a disc, 4 a rect, 6 or more a polygon.
    explicit = WorldParams(obstacles=LAYOUT).arena()
    bare = WorldParams(obstacles={name: values[1:] for name, values in LAYOUT.items()}).arena()
    assert bare == explicit


def test_a_polygon_given_clockwise_is_turned_counter_clockwise():
    given = [0.4, 0.4, 0.6, 0.9, 0.9, 0.5]
    (wedge,) = WorldParams(obstacles={'wedge': ['polygon', *given]}).arena().obstacles
    assert wedge.vertices == ((0.9, 0.5), (0.6, 0.9), (0.4, 0.4))
    assert wedge.clearance(0.6, 0.6) < 0 < wedge.clearance(0.3, 0.3)


def test_clearance_of_each_kind():
    disc = Disc('d', 1.0, 1.0, 0.2)
    assert disc.clearance(1.5, 1.0) == pytest.approx(0.3)
    assert disc.clearance(1.0, 1.0) == pytest.approx(-0.2)
    rect = Rect.of('r', 1.0, 1.0, 2.0, 1.5)
    assert rect.clearance(0.7, 1.2) == pytest.approx(0.3)  # beside an edge
    assert rect.clearance(2.3, 1.9) == pytest.approx(0.5)  # off a corner: 0.3, 0.4, 0.5
    assert rect.clearance(1.5, 1.1) == pytest.approx(-0.1)  # inside, 0.1 from an edge
    walls = Arena(2.0).shapes[0]
    assert walls.clearance(0.1, 1.0) == pytest.approx(0.1)
    assert walls.clearance(2.05, 1.0) == pytest.approx(-0.05)
    assert Arena(2.0, (rect,)).clearance(1.9, 1.7) == pytest.approx(0.1)  # the wall


def test_pack_puts_each_arenas_obstacles_in_its_bounds():
    first = WorldParams(obstacles=LAYOUT).arena()
    second = Arena(2.85, (Disc('a', 0.5, 0.5, 0.1),))
    packed = pack([first, Arena(2.85), second])
    assert packed.bounds.tolist() == [0, 3, 3, 4]
    assert packed.kinds.tolist() == [0, 1, 1, 0]  # disc, rect, polygon, disc
    assert packed.first.tolist() == [0, 1, 5, 8, 9]  # 1 row, 4 edges, 3 edges, 1 row
    assert packed.geometry[0].tolist() == [0.9, 2.0, 0.15, 0.0]
    assert packed.geometry[1].tolist() == [1.8, 0.5, 1.9, 0.5]  # the rect's bottom edge
    np.testing.assert_array_equal(packed.boxes[3], [0.4, 0.4, 0.6, 0.6])


def test_floor_area_and_cells_under():
    arena = Arena(1.0, (Rect.of('r', 0.0, 0.0, 0.5, 0.2), Disc('d', 0.7, 0.7, 0.1)))
    assert arena.floor_area == pytest.approx(1.0 - 0.1 - math.pi * 0.01)
    under = arena.under(10, 0.1)  # cell centres at 0.05, 0.15, ...
    assert under[:2, :5].all() and under[6:8, 6:8].all()  # row = y
    assert under.sum() == 10 + 4  # the rect's 2 x 5 cells, the 4 within 7 cm of (0.7, 0.7)


@pytest.mark.parametrize('values, fragment', [
    (['circle', 1.0, 1.0, 0.1], "world.obstacles.box: unknown kind 'circle' (kinds: disc, "
                                'rect, polygon)'),
    (['disc', 1.0, 1.0], "world.obstacles.box = ['disc', 1.0, 1.0]: a disc takes 3 numbers"),
    (['rect', 1.0, 1.0, 2.0], "world.obstacles.box = ['rect', 1.0, 1.0, 2.0]: a rect takes "
                              '4 numbers'),
    (['polygon', 1.0, 1.0, 2.0, 1.0], 'a polygon takes x, y pairs of 3 or more vertices'),
    (['polygon', 1.0, 1.0, 2.0, 1.0, 2.0], 'a polygon takes x, y pairs'),
    ([1.0, 1.0, 1.0, 2.0, 2.0], 'world.obstacles.box = [1.0, 1.0, 1.0, 2.0, 2.0]: a polygon'),
    (['disc', 1.0, 'one', 0.1], "world.obstacles.box = ['disc', 1.0, 'one', 0.1]: "
                                'expected [kind, numbers...]'),
    (['disc', 1.0, True, 0.1], 'expected [kind, numbers...]'),
    (['disc', 1.0, 1.0, 0.0], 'world.obstacles.box: a disc of radius 0.0 m is degenerate'),
    (['disc', 2.8, 1.0, 0.1], 'world.obstacles.box: the point (2.9, 1.1) is outside the '
                              '2.85 m arena'),
    (['rect', 1.0, 1.0, 1.0, 2.0], 'world.obstacles.box: a rect is [x0, y0, x1, y1] with '
                                   'x0 < x1 and y0 < y1'),
    (['rect', 2.0, 1.0, 1.0, 2.0], 'x0 < x1 and y0 < y1'),
    (['rect', -0.1, 1.0, 1.0, 2.0], 'world.obstacles.box: the point (-0.1, 1.0) is outside'),
    (['polygon', 1.0, 1.0, 3.0, 1.0, 2.0, 2.0], 'the point (3.0, 1.0) is outside the 2.85 m'),
    (['polygon', 1.0, 1.0, 1.0, 1.0, 2.0, 2.0], 'world.obstacles.box: the polygon repeats the '
                                                'vertex (1.0, 1.0) (degenerate)'),
    (['polygon', 1.0, 1.0, 1.5, 1.5, 2.0, 2.0], 'world.obstacles.box: the polygon has three '
                                                'vertices in a line (degenerate)'),
    (['polygon', 0.1, 0.1, 1.0, 0.1, 1.0, 1.0, 0.5, 0.3, 0.1, 1.0],
     'world.obstacles.box: the polygon is not convex'),
    # A pentagram: every corner turns the same way, but it winds twice.
    (['polygon', *np.ravel([(1.0 + 0.5 * math.cos(a), 1.0 + 0.5 * math.sin(a))
                            for a in np.arange(5) * 4 * math.pi / 5]).tolist()],
     'the polygon is not convex (or crosses itself)'),
    (['disc', 1.4, 1.4, 0.1], "world.obstacles.box: covers the centre (1.425, 1.425) of "
                              "source 'source'"),
    (['disc', math.inf, 1.0, 0.1], 'expected finite numbers'),
])
def test_bad_obstacles_are_refused_naming_the_key(values, fragment):
    with pytest.raises(ParameterError) as error:
        WorldParams(obstacles={'box': values})
    assert fragment in str(error.value)


def test_bad_names_and_covered_sources_through_the_whole_config():
    with pytest.raises(ParameterError, match=r'world.obstacles.Box: an obstacle name must be '
                                             r'a lower-case identifier'):
        SwarmConfig().replace(world={'obstacles': {'Box': ['disc', 1.0, 1.0, 0.1]}})
    with pytest.raises(ParameterError, match=r"world.obstacles.box: covers the centre "
                                             r"\(0.8, 2.0\) of source 'west'"):
        SwarmConfig().replace(world={'sources': {'west': [0.8, 2.0, 0.5, 255.0]},
                                     'obstacles': {'box': ['rect', 0.7, 1.9, 0.9, 2.1]}})
    with pytest.raises(ParameterError, match=r'world.obstacles.box = 3: expected a non-empty'):
        SwarmConfig().replace(world={'obstacles': {'box': 3}})


def test_obstacle_cue_keep_leaves_the_cue_as_without_obstacles():
    bare = initial_cue(WorldParams())
    kept = initial_cue(WorldParams(obstacles=LAYOUT))
    assert kept.dtype == np.float32 and np.array_equal(kept, bare)


def test_obstacle_cue_clear_empties_the_cells_under_obstacles_only():
    params = WorldParams(obstacles=LAYOUT, obstacle_cue='clear')
    bare, cleared = initial_cue(WorldParams()), initial_cue(params)
    under = params.arena().under(params.cells, params.cell_size)
    assert (cleared[under] == 0).all() and (bare[under] > 0).any()
    assert np.array_equal(cleared[~under], bare[~under])
    # The pillar at (0.9, 2.0), radius 0.15: about pi 0.15^2 / 0.01^2 = 707 cells.
    assert abs(under.sum() - (707 + 10 * 80 + 1150)) < 100
    mona, sensing = MonaParams(), SensingParams()
    assert CueField(params, mona, sensing).initial_mean < \
        CueField(WorldParams(), mona, sensing).initial_mean
    assert not params.paper_field and WorldParams(obstacles=LAYOUT).paper_field


def test_obstacle_cue_clear_applies_to_a_cue_file_too(tmp_path):
    path = tmp_path / 'map.npy'
    np.save(path, np.full((10, 10), 200.0))
    params = WorldParams(cue_file=str(path), obstacles=LAYOUT, obstacle_cue='clear')
    cue = initial_cue(params)
    under = params.arena().under(params.cells, params.cell_size)
    assert (cue[under] == 0).all() and (cue[~under] == 200).all()


def test_a_bad_obstacle_cue_is_refused():
    with pytest.raises(ParameterError, match=r"world.obstacle_cue = 'wipe' is not allowed"):
        WorldParams(obstacle_cue='wipe')


# --- Episodes among obstacles (the embedded engine) -------------------------------------

#: Pillars, a wall segment and a sharp wedge around the paper's source, where robots gather.
CROWDED = {'pillar_a': ['disc', 1.0, 1.0, 0.12], 'pillar_b': ['disc', 1.9, 1.9, 0.12],
           'pillar_c': ['disc', 1.05, 1.95, 0.08], 'wall': ['rect', 1.6, 0.6, 1.66, 1.3],
           'wedge': ['polygon', 1.7, 1.5, 2.0, 1.3, 2.1, 1.6]}


def clearances(obstacles, xy: np.ndarray) -> np.ndarray:
    """[N] each point's distance to the nearest obstacle (m), negative inside one."""
    nearest = np.full(len(xy), np.inf)
    x, y = xy[:, 0], xy[:, 1]
    for obstacle in obstacles:
        if isinstance(obstacle, Disc):
            distance = np.hypot(x - obstacle.x, y - obstacle.y) - obstacle.radius
        else:
            edges = []
            for (ax, ay), (bx, by) in obstacle.edges:
                ex, ey = bx - ax, by - ay
                f = np.clip(((x - ax) * ex + (y - ay) * ey) / (ex * ex + ey * ey), 0.0, 1.0)
                edges.append(np.hypot(x - ax - f * ex, y - ay - f * ey))
            distance = np.min(edges, axis=0)
            distance[obstacle.covers(x, y)] *= -1.0
        nearest = np.minimum(nearest, distance)
    return nearest


def test_the_vectorised_clearance_is_the_arenas():
    arena = WorldParams(obstacles=CROWDED).arena()
    xy = np.random.default_rng(1).uniform(0.0, 2.85, (300, 2))
    expected = [min(obstacle.clearance(x, y) for obstacle in arena.obstacles) for x, y in xy]
    np.testing.assert_allclose(clearances(arena.obstacles, xy), expected, atol=1e-12)


def test_robots_never_enter_an_obstacle_and_see_it_as_a_wall():
    config = SwarmConfig().replace(episode={'population': 50, 'seed': 2, 'duration': 120.0},
                                   world={'obstacles': CROWDED})
    episode = Episode(config)
    world, mona = episode.world, config.mona
    obstacles = world.arena.obstacles
    # How far a body may press into an obstacle: pymunk moves it by its velocity before it
    # detects the contact, so on first contact a robot can be up to one step's travel in (at
    # most the wheels' top speed, 13.3 cm/s x 32 ms = 4.3 mm; a robot whose beams miss the
    # wedge's sharp corner drives into it), then the solver pushes it back to the collision
    # slop (0.5 mm) within a few steps. Measured here: 1.8 mm, at the wedge's corner.
    top_speed = mona.max_wheel_command * mona.wheel_unit_speed
    tolerance = config.world.collision_slop + top_speed * config.world.step_period
    deepest, contacts, seen = math.inf, 0, 0
    while not episode.done:
        episode.step()
        gap = clearances(obstacles, world.poses[:, :2]) - mona.body_radius
        deepest = min(deepest, gap.min())
        contacts += int((gap < 0.001).sum())
        if world.steps % 50 == 0:  # the world's IR among the obstacles is the reference's
            readings = world.sense()
            ranges, is_robot = check_ir(world.poses, mona.body_radius, world.bearings,
                                        mona.ir_range, world.arena)
            assert np.array_equal(readings.ranges, ranges)
            assert np.array_equal(readings.is_robot, is_robot)
            near = gap < mona.ir_range
            seen += int((np.isfinite(ranges[near]) & ~is_robot[near]).sum())
    assert deepest >= -tolerance
    assert contacts > 20 and seen > 20  # robots met the obstacles, and saw them as walls
    assert episode.controllers.encounters.sum() > 0


def test_the_ir_sees_an_obstacle_where_the_bare_arena_sees_nothing():
    config = SwarmConfig().replace(episode={'population': 40, 'seed': 4, 'duration': 1.0},
                                   world={'obstacles': CROWDED})
    episode = Episode(config)
    world, mona = episode.world, config.mona
    # Put robot 0 2 cm from pillar_a's west side, facing it.
    poses = world.poses.copy()
    poses[0] = (1.0 - 0.12 - 0.06, 1.0, 0.0)
    world.reset(poses, 4)
    readings = world.sense()
    assert readings.ranges[0, 2] == pytest.approx(0.02, abs=1e-6)
    assert not readings.is_robot[0, 2]
    bare = proximity(poses, mona.body_radius, world.bearings, mona.ir_range, 2.85)
    assert np.isinf(bare[0][0, 2])


def test_episode_placement_avoids_the_obstacles():
    arena = WorldParams(obstacles=CROWDED).arena()
    for seed in (1, 2, 3):
        poses = check_placement(50, arena, 0.04, seed)
        assert clearances(arena.obstacles, poses[:, :2]).min() >= 0.045 - 1e-12
    episode = Episode(SwarmConfig().replace(episode={'population': 50, 'seed': 1},
                                                   world={'obstacles': CROWDED}))
    assert np.array_equal(episode.world.poses, check_placement(50, arena, 0.04, 1))


def mixed_layouts() -> list[SwarmConfig]:
    """Episodes with different obstacles (none, LAYOUT, CROWDED with the cue cleared under
    them), populations, seeds and noise."""
    base = SwarmConfig().replace(episode={'duration': 25.0})
    return [
        base.replace(episode={'population': 20, 'seed': 3}, world={'obstacles': CROWDED}),
        base.replace(episode={'population': 12, 'seed': 1}),
        base.replace(episode={'population': 30, 'seed': 5, 'duration': 18.0},
                     world={'obstacles': LAYOUT}, sensing={'ir_miss': 0.1, 'wheel_noise': 0.05}),
        base.replace(episode={'population': 25, 'seed': 2},
                     world={'obstacles': CROWDED, 'obstacle_cue': 'clear'},
                     controller={'speed': 0.04}),
    ]


def test_a_batch_of_mixed_obstacle_layouts_equals_each_episode_alone():
    configs = mixed_layouts()
    lone = [Episode(config) for config in configs]
    order = [2, 0, 3, 1]
    batched = [Episode(configs[k]) for k in order]
    batch = Batch(batched)
    expected_batch = [lone[k] for k in order]
    while not batch.done:
        for member, readings in zip(batch.active, batch.readings()):
            alone = expected_batch[batched.index(member)]
            expected = alone.world.sense()
            assert readings.time_ns == expected.time_ns
            assert np.array_equal(readings.ground, expected.ground)
            assert np.array_equal(readings.ranges, expected.ranges)
            assert np.array_equal(readings.is_robot, expected.is_robot)
        stepped = batch.step()
        for member, _ in stepped:
            alone = expected_batch[batched.index(member)]
            alone.step()
            assert np.array_equal(member.world.poses, alone.world.poses)
    for member, alone in zip(batched, expected_batch):
        assert member.steps_done == alone.steps_done == alone.steps_total
        assert np.array_equal(member.world.cue, alone.world.cue)
        assert np.array_equal(member.controllers.encounters, alone.controllers.encounters)
    assert sum(alone.controllers.encounters.sum() for alone in lone) > 0


def test_a_batch_of_obstacle_layouts_through_the_runner_equals_the_lone_runs():
    """run_batch against run_episode: the whole runner path, outputs included (placed by
    place_swarm, which does not know the obstacles yet: bodies may start inside one and be
    pushed out, the same way in both)."""
    configs = mixed_layouts()
    alone = [run_episode(config) for config in configs]
    batched = run_batch(configs)
    for lone, result in zip(alone, batched):
        assert result.metrics == lone.metrics
        for name in ('initial_poses', 'final_poses', 'final_cue'):
            assert np.array_equal(getattr(result, name), getattr(lone, name)), name


def test_the_obstacles_design_loads_and_is_a_valid_ros_parameter_file():
    design = Path(__file__).resolve().parents[2] / 'ros_ws/config/designs/obstacles.yaml'
    config = load_config(design)
    arena = config.world.arena()
    assert [o.kind for o in arena.obstacles] == ['disc'] * 4 + ['rect']
    assert config.study.factors == (('world.obstacle_cue', ('keep', 'clear')),)
    # rcl refuses a list mixing types (strings and numbers, or integers and floats).
    raw = yaml.safe_load(design.read_text())['/**']['ros__parameters']['world']['obstacles']
    assert all(all(type(v) is float for v in values) for values in raw.values())
