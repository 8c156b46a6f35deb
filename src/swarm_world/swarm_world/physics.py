"""Rigid-body physics of the Monas in the walled arena (pymunk).

Each Mona is a dynamic disc. Every step sets its velocity from the commanded linear and
angular speed (differential drive, no wheel slip modelled) and lets pymunk resolve contacts,
so robots push each other and stop at walls. All bodies are read and written in one batch
call (a per-body Python loop costs about 5x).
"""

from __future__ import annotations

import numpy as np
import pymunk
import pymunk.batch

BODY_MASS = 0.1  # kg; only the ratio between robots matters, and all are equal
WALL_THICKNESS = 0.05  # m, outside the arena so the inner faces sit exactly on its edges

_POSE = pymunk.batch.BodyFields.POSITION | pymunk.batch.BodyFields.ANGLE
_TWIST = pymunk.batch.BodyFields.VELOCITY | pymunk.batch.BodyFields.ANGULAR_VELOCITY


class Physics:
    """A pymunk space holding N robot discs inside four walls. Rebuild it for every episode
    (pymunk's contact caches would otherwise make replays diverge)."""

    def __init__(self, arena_side: float, body_radius: float, poses: np.ndarray,
                 collision_slop: float) -> None:
        self.space = pymunk.Space()
        self.space.collision_slop = collision_slop
        self.count = len(poses)
        moment = pymunk.moment_for_circle(BODY_MASS, 0.0, body_radius)
        for x, y, theta in poses:
            body = pymunk.Body(BODY_MASS, moment)
            body.position = (float(x), float(y))
            body.angle = float(theta)
            shape = pymunk.Circle(body, body_radius)
            shape.elasticity = 0.0
            shape.friction = 0.0
            self.space.add(body, shape)
        half, side = WALL_THICKNESS / 2, arena_side
        for a, b in (((-half, -half), (side + half, -half)),
                     ((side + half, -half), (side + half, side + half)),
                     ((side + half, side + half), (-half, side + half)),
                     ((-half, side + half), (-half, -half))):
            wall = pymunk.Segment(self.space.static_body, a, b, half)
            wall.elasticity = 0.0
            wall.friction = 0.0
            self.space.add(wall)
        self._read = pymunk.batch.Buffer()
        self._write = pymunk.batch.Buffer()
        # The space also lists its static body last: the buffers carry one spare row.
        self._twist = np.zeros((self.count + 1, 3))
        self.poses = np.array(poses, dtype=np.float64).reshape(-1, 3)

    def step(self, linear: np.ndarray, angular: np.ndarray, dt: float) -> np.ndarray:
        """Drive every robot at (linear m/s, angular rad/s) for ``dt`` seconds; return poses."""
        if self.count == 0:
            return self.poses
        heading = self.poses[:, 2]
        self._twist[:self.count, 0] = linear * np.cos(heading)
        self._twist[:self.count, 1] = linear * np.sin(heading)
        self._twist[:self.count, 2] = angular
        self._write.set_float_buf(self._twist)
        pymunk.batch.set_space_bodies(self.space, _TWIST, self._write)
        self.space.step(dt)
        self._read.clear()
        pymunk.batch.get_space_bodies(self.space, _POSE, self._read)
        raw = np.frombuffer(self._read.float_buf(), dtype=np.float64)
        self.poses = raw.reshape(-1, 3)[:self.count].copy()
        return self.poses
