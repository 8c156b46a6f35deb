"""Rigid-body physics of the Monas in the walled arena (pymunk).

Each Mona is a dynamic disc driven by the commanded linear and angular speed (differential
drive, no wheel slip modelled). The command is applied as the force that brings the body to
that velocity within the step, so pymunk's contact solver corrects it before positions move:
robots push each other and stop at walls instead of sinking in. (pymunk integrates positions
at the start of a step with the velocity the previous step's solver left, so a command moves
the robot one step later: a 32 ms actuation delay.) All bodies are read and written in one
batch call (a per-body Python loop costs about 5x).

Each robot also carries a sensor ring (a pymunk sensor shape, no collision response) as wide
as its IR reach. pymunk's broadphase reports when a ring starts or stops touching another
robot or a wall, so the IR model only casts beams for robots that can see something.
"""

from __future__ import annotations

import numpy as np
import pymunk
import pymunk.batch

BODY_MASS = 0.1  # kg; only the ratio between robots matters, and all are equal
WALL_THICKNESS = 0.05  # m, outside the arena so the inner faces sit exactly on its edges
RING_MARGIN = 0.01  # m added to the ring so a candidate is never missed within one step

_FIELDS = pymunk.batch.BodyFields
_STATE = _FIELDS.POSITION | _FIELDS.ANGLE | _FIELDS.VELOCITY | _FIELDS.ANGULAR_VELOCITY
_WRENCH = _FIELDS.FORCE | _FIELDS.TORQUE
_BODY, _RING, _WALL = 1, 2, 3  # collision types (and filter category bits)


class Physics:
    """A pymunk space holding N robot discs inside four walls. Rebuild it for every episode
    (pymunk's contact caches would otherwise make replays diverge)."""

    def __init__(self, arena_side: float, body_radius: float, poses: np.ndarray,
                 collision_slop: float, ring_radius: float | None = None) -> None:
        self.space = pymunk.Space()
        self.space.collision_slop = collision_slop
        self.count = len(poses)
        self.ring_pairs: set[tuple[int, int]] = set()  # (robot, other robot) rings touching
        self.ring_walls: dict[int, int] = {}  # robot -> number of walls its ring touches
        self._candidates: tuple[np.ndarray, np.ndarray] | None = None  # cache until a change
        moment = pymunk.moment_for_circle(BODY_MASS, 0.0, body_radius)
        self._inertia = np.array([BODY_MASS, BODY_MASS, moment])
        body_filter = pymunk.ShapeFilter(categories=_BODY, mask=_BODY | _RING | _WALL)
        ring_filter = pymunk.ShapeFilter(categories=_RING, mask=_BODY | _WALL)
        for index, (x, y, theta) in enumerate(poses):
            body = pymunk.Body(BODY_MASS, moment)
            body.position = (float(x), float(y))
            body.angle = float(theta)
            shape = pymunk.Circle(body, body_radius)
            shape.elasticity = 0.0
            shape.friction = 0.0
            shape.collision_type = _BODY
            shape.filter = body_filter
            shape.robot = index
            self.space.add(body, shape)
            if ring_radius is not None:
                ring = pymunk.Circle(body, ring_radius + RING_MARGIN)
                ring.sensor = True
                ring.collision_type = _RING
                ring.filter = ring_filter
                ring.robot = index
                self.space.add(ring)
        half, side = WALL_THICKNESS / 2, arena_side
        wall_filter = pymunk.ShapeFilter(categories=_WALL, mask=_BODY | _RING)
        for a, b in (((-half, -half), (side + half, -half)),
                     ((side + half, -half), (side + half, side + half)),
                     ((side + half, side + half), (-half, side + half)),
                     ((-half, side + half), (-half, -half))):
            wall = pymunk.Segment(self.space.static_body, a, b, half)
            wall.elasticity = 0.0
            wall.friction = 0.0
            wall.collision_type = _WALL
            wall.filter = wall_filter
            self.space.add(wall)
        self.space.on_collision(_RING, _BODY, begin=self._ring_robot_begin,
                                separate=self._ring_robot_end)
        self.space.on_collision(_RING, _WALL, begin=self._ring_wall_begin,
                                separate=self._ring_wall_end)
        self._read = pymunk.batch.Buffer()
        self._write = pymunk.batch.Buffer()
        # The space also lists its static body last: the buffers carry one spare row.
        self._wrench = np.zeros((self.count + 1, 3))
        self.poses = np.array(poses, dtype=np.float64).reshape(-1, 3)
        self.twist = np.zeros((self.count, 3))  # (vx, vy, omega) after the last solve
        self.cos = np.cos(self.poses[:, 2])
        self.sin = np.sin(self.poses[:, 2])
        self.space.step(1e-9)  # find the ring contacts of the initial placement (nothing moves)

    def _ring_robot_begin(self, arbiter: pymunk.Arbiter, space, data) -> None:
        self._candidates = None
        ring, other = arbiter.shapes
        self.ring_pairs.add((ring.robot, other.robot))

    def _ring_robot_end(self, arbiter: pymunk.Arbiter, space, data) -> None:
        self._candidates = None
        ring, other = arbiter.shapes
        self.ring_pairs.discard((ring.robot, other.robot))

    def _ring_wall_begin(self, arbiter: pymunk.Arbiter, space, data) -> None:
        self._candidates = None
        robot = arbiter.shapes[0].robot
        self.ring_walls[robot] = self.ring_walls.get(robot, 0) + 1

    def _ring_wall_end(self, arbiter: pymunk.Arbiter, space, data) -> None:
        self._candidates = None
        robot = arbiter.shapes[0].robot
        left = self.ring_walls.get(robot, 0) - 1
        if left > 0:
            self.ring_walls[robot] = left
        else:
            self.ring_walls.pop(robot, None)

    def candidates(self) -> tuple[np.ndarray, np.ndarray]:
        """Robots whose IR ring touches a wall, and (robot, other) pairs whose rings touch."""
        if self._candidates is None:
            walls = np.array(sorted(self.ring_walls), dtype=np.int64)
            pairs = np.array(sorted(self.ring_pairs), dtype=np.int64).reshape(-1, 2)
            self._candidates = (walls, pairs)
        return self._candidates

    def step(self, linear: np.ndarray, angular: np.ndarray, dt: float) -> np.ndarray:
        """Drive every robot at (linear m/s, angular rad/s) for ``dt`` seconds; return poses."""
        if self.count == 0:
            return self.poses
        wrench = self._wrench[:self.count]
        np.multiply(linear, self.cos, out=wrench[:, 0])
        np.multiply(linear, self.sin, out=wrench[:, 1])
        wrench[:, 2] = angular
        wrench -= self.twist
        wrench *= self._inertia / dt
        self._write.set_float_buf(self._wrench)
        pymunk.batch.set_space_bodies(self.space, _WRENCH, self._write)
        self.space.step(dt)
        self._read.clear()
        pymunk.batch.get_space_bodies(self.space, _STATE, self._read)
        state = np.frombuffer(self._read.float_buf(), dtype=np.float64).reshape(-1, 6)
        self.poses = state[:self.count, :3].copy()
        self.twist = state[:self.count, 3:].copy()
        self.cos = np.cos(self.poses[:, 2])
        self.sin = np.sin(self.poses[:, 2])
        return self.poses
