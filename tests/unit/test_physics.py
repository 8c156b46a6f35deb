"""Physics against pymunk's public batch API: the same space, the same wrench, the same bits.

``Physics.step`` drives pymunk through its private batch iterators with argument blocks built
once, and computes the wrench in a compiled kernel. Here a twin space is stepped through the
public ``pymunk.batch`` functions and ``Space.step`` with the wrench written out in numpy; both
must agree bit for bit at every step, so a pymunk upgrade that changes what the private path
relies on fails here first.
"""

import math

import numpy as np
import pymunk
import pymunk.batch
import pytest

from swarm_world.arena import Disc, Polygon, Rect
from swarm_world.physics import BODY_MASS, Physics

SIDE, RADIUS, SLOP, DT = 1.0, 0.04, 0.0005, 0.032
OBSTACLES = (Disc('pillar', 0.5, 0.5, 0.1), Rect.of('wall', 0.75, 0.2, 0.8, 0.8),
             Polygon('wedge', ((0.1, 0.7), (0.3, 0.75), (0.2, 0.9))))
STATE = (pymunk.batch.BodyFields.POSITION | pymunk.batch.BodyFields.ANGLE
         | pymunk.batch.BodyFields.VELOCITY | pymunk.batch.BodyFields.ANGULAR_VELOCITY)
WRENCH = pymunk.batch.BodyFields.FORCE | pymunk.batch.BodyFields.TORQUE


class PublicStepper:
    """A space stepped by pymunk's public API only: get the state, compute the wrench that
    takes each body to its command within the step, set it, ``Space.step``."""

    def __init__(self, space: pymunk.Space, count: int) -> None:
        self.space, self.count = space, count
        moment = pymunk.moment_for_circle(BODY_MASS, 0.0, RADIUS)
        self.scale = np.array([BODY_MASS, BODY_MASS, moment]) / DT
        self.state = pymunk.batch.Buffer()
        self.wrench = np.zeros((count + 1, 3))  # pymunk visits the static body too
        self.wrench_buffer = pymunk.batch.Buffer()
        self.wrench_buffer.set_float_buf(self.wrench)

    def read(self) -> np.ndarray:
        self.state.clear()
        pymunk.batch.get_space_bodies(self.space, STATE, self.state)
        return np.frombuffer(self.state.float_buf(), dtype=np.float64).reshape(-1, 6)[
            :self.count].copy()

    def step(self, linear: np.ndarray, angular: np.ndarray) -> np.ndarray:
        state = self.read()
        cos = np.array([math.cos(angle) for angle in state[:, 2]])
        sin = np.array([math.sin(angle) for angle in state[:, 2]])
        self.wrench[:self.count, 0] = (linear * cos - state[:, 3]) * self.scale[0]
        self.wrench[:self.count, 1] = (linear * sin - state[:, 4]) * self.scale[1]
        self.wrench[:self.count, 2] = (angular - state[:, 5]) * self.scale[2]
        pymunk.batch.set_space_bodies(self.space, WRENCH, self.wrench_buffer)
        self.space.step(DT)
        return self.read()


def crowd(rng: np.random.Generator) -> np.ndarray:
    """Twelve robots 1 cm apart in a row and beside the obstacles, random headings."""
    xy = [(x, 0.3) for x in (0.1, 0.19, 0.28, 0.37, 0.46, 0.55, 0.64, 0.9)]
    xy += [(0.1, 0.5), (0.3, 0.5), (0.7, 0.5), (0.2, 0.6)]
    return np.column_stack((xy, rng.uniform(-math.pi, math.pi, len(xy))))


@pytest.mark.parametrize('obstacles', [(), OBSTACLES], ids=['bare', 'obstacles'])
def test_physics_steps_as_pymunks_public_batch_api(obstacles):
    rng = np.random.default_rng(4)
    poses = crowd(rng)
    assert all(obstacle.clearance(x, y) > RADIUS for obstacle in OBSTACLES for x, y, _ in poses)
    ours = Physics(SIDE, RADIUS, poses, SLOP, obstacles)
    twin = Physics(SIDE, RADIUS, poses, SLOP, obstacles)  # the same space, stepped publicly
    theirs = PublicStepper(twin.space, len(poses))
    touched = 0
    for _ in range(400):
        linear = rng.uniform(-0.02, 0.1, len(poses))
        angular = rng.uniform(-2.0, 2.0, len(poses))
        ours.step(linear, angular, DT)
        state = theirs.step(linear, angular)
        np.testing.assert_array_equal(ours.poses, state[:, :3])
        np.testing.assert_array_equal(ours.twist, state[:, 3:])
        touched += sum(obstacle.clearance(x, y) < RADIUS + 0.002
                       for obstacle in obstacles for x, y, _ in ours.poses)
    assert touched > 50 if obstacles else touched == 0  # obstacle contacts were exercised


def test_an_obstacle_is_a_static_shape_as_the_walls():
    physics = Physics(SIDE, RADIUS, np.zeros((0, 3)), SLOP, OBSTACLES)
    shapes = [shape for shape in physics.space.shapes if shape.body is physics.space.static_body]
    assert len(shapes) == 4 + 3
    assert {type(shape) for shape in shapes[4:]} == {pymunk.Circle, pymunk.Poly}
    assert all(shape.elasticity == 0.0 and shape.friction == 0.0 for shape in shapes)
    circle, box, wedge = shapes[4:]
    assert circle.offset == (0.5, 0.5) and circle.radius == 0.1
    assert sorted(box.get_vertices()) == sorted(OBSTACLES[1].vertices)
    assert len(wedge.get_vertices()) == 3
