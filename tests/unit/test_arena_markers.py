"""The arena's obstacles as /world/obstacles marker data (swarm_world.messages.markers): one
marker per obstacle, stable ids, the right kind, pose and size, and back to the shapes."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from swarm_world.arena import Arena, Disc, Polygon, Rect
from swarm_world.messages import markers as arena_markers
from swarm_world.messages.markers import (
    CUBE,
    CYLINDER,
    HEIGHT,
    TRIANGLE_LIST,
    obstacle_markers,
    obstacles_from_markers,
)
from swarm_world.params import WorldParams

LAYOUT = {'pillar': [0.9, 2.0, 0.15], 'wall': [1.8, 0.5, 1.9, 1.3],
          'wedge': [0.4, 0.4, 0.9, 0.5, 0.6, 0.9], 'box': [0.2, 0.2, 0.3, 0.9, 0.1, 0.8]}


def decoded(data: arena_markers.MarkerData) -> SimpleNamespace:
    """The marker as a decoder shows it (attribute access, as rclpy, rosbags and mcap do)."""
    xyz = ('x', 'y', 'z')
    return SimpleNamespace(
        ns=arena_markers.NAMESPACE, id=data.id, type=data.type, action=arena_markers.ADD,
        text=data.text, pose=SimpleNamespace(position=SimpleNamespace(**dict(zip(xyz,
                                                                             data.position)))),
        scale=SimpleNamespace(**dict(zip(xyz, data.scale))),
        points=[SimpleNamespace(**dict(zip(xyz, p))) for p in data.points])


def test_one_marker_per_obstacle_in_name_order_with_stable_ids():
    arena = WorldParams(obstacles=LAYOUT).arena()
    markers = obstacle_markers(arena)
    assert [(m.id, m.text, m.type) for m in markers] == [
        (0, 'box', TRIANGLE_LIST), (1, 'pillar', CYLINDER), (2, 'wall', CUBE),
        (3, 'wedge', TRIANGLE_LIST)]
    assert obstacle_markers(WorldParams(obstacles=LAYOUT).arena()) == markers  # stable
    assert obstacle_markers(Arena(2.85)) == ()


def test_disc_and_rect_markers_stand_on_the_floor_where_the_shapes_are():
    _, pillar, wall, _ = obstacle_markers(WorldParams(obstacles=LAYOUT).arena())
    assert pillar.position == (0.9, 2.0, HEIGHT / 2)
    assert pillar.scale == (0.3, 0.3, HEIGHT)
    assert pillar.position[2] - pillar.scale[2] / 2 == 0.0  # from the floor up
    assert wall.position == pytest.approx((1.85, 0.9, HEIGHT / 2))
    assert wall.scale == pytest.approx((0.1, 0.8, HEIGHT))


def test_a_polygon_is_a_prism_whose_top_face_covers_it_facing_up_and_walls_facing_out():
    wedge = Polygon('wedge', ((0.4, 0.4), (0.9, 0.5), (0.6, 0.9), (0.45, 0.8)))
    (marker,) = obstacle_markers(Arena(2.85, (wedge,)))
    triangles = np.array(marker.points).reshape(-1, 3, 3)
    n = len(wedge.vertices)
    assert len(triangles) == 3 * n - 2 and marker.scale == (1.0, 1.0, 1.0)
    top, walls = triangles[:n - 2], triangles[n - 2:]
    assert np.all(top[:, :, 2] == HEIGHT)
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    assert np.all(normals[:n - 2, 2] > 0)  # the top faces up
    # The top face's triangles cover the polygon's area exactly once.
    assert np.sum(normals[:n - 2, 2]) / 2 == pytest.approx(wedge.area)
    # Each wall faces away from the polygon's centre.
    centre = np.mean(wedge.vertices, axis=0)
    middles = walls.mean(axis=1)[:, :2]
    assert np.all(np.einsum('ij,ij->i', normals[n - 2:, :2], middles - centre) > 0)
    assert {p[2] for p in marker.points} == {0.0, HEIGHT}


def test_markers_read_back_into_the_shapes():
    arena = WorldParams(obstacles=LAYOUT).arena()
    shapes = obstacles_from_markers(decoded(m) for m in obstacle_markers(arena))
    assert [s.name for s in shapes] == [o.name for o in arena.obstacles]
    for shape, obstacle in zip(shapes, arena.obstacles):
        assert type(shape) is type(obstacle)
        if isinstance(obstacle, Disc):
            assert shape == obstacle
        elif isinstance(obstacle, Rect):
            assert np.allclose(shape.vertices, obstacle.vertices, rtol=0, atol=1e-12)
        else:
            assert shape.vertices == obstacle.vertices
    # Other namespaces, actions and kinds are not obstacles.
    other = decoded(obstacle_markers(arena)[1])
    other.ns = 'robots'
    deleted = decoded(obstacle_markers(arena)[1])
    deleted.action = 3
    assert obstacles_from_markers([other, deleted]) == ()


@pytest.mark.parametrize('sides', [3, 5, 12])
def test_regular_polygons_read_back(sides):
    angles = np.arange(sides) * 2 * math.pi / sides
    vertices = tuple((1.0 + 0.3 * math.cos(a), 1.0 + 0.3 * math.sin(a)) for a in angles)
    (marker,) = obstacle_markers(Arena(2.85, (Polygon('p', vertices),)))
    assert obstacles_from_markers([decoded(marker)]) == (Polygon('p', vertices),)
