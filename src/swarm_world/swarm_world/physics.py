"""Rigid-body physics of the Monas in the walled arena (pymunk).

Each Mona is a dynamic disc driven by the commanded linear and angular speed (differential
drive, no wheel slip modelled). The command is applied as the force that brings the body to
that velocity within the step, so pymunk's contact solver corrects it before positions move:
robots push each other and stop at walls instead of sinking in. (pymunk integrates positions
at the start of a step with the velocity the previous step's solver left, so a command moves
the robot one step later: a 32 ms actuation delay.) All bodies are read and written in one
batch call (a per-body Python loop costs about 5x).
"""

from __future__ import annotations

import numpy as np
import pymunk
import pymunk.batch

BODY_MASS = 0.1  # kg; only the ratio between robots matters, and all are equal
WALL_THICKNESS = 0.05  # m, outside the arena so the inner faces sit exactly on its edges

_FIELDS = pymunk.batch.BodyFields
_STATE = _FIELDS.POSITION | _FIELDS.ANGLE | _FIELDS.VELOCITY | _FIELDS.ANGULAR_VELOCITY
_WRENCH = _FIELDS.FORCE | _FIELDS.TORQUE


class Physics:
    """A pymunk space holding N robot discs inside four walls. Rebuild it for every episode
    (pymunk's contact caches would otherwise make replays diverge)."""

    def __init__(self, arena_side: float, body_radius: float, poses: np.ndarray,
                 collision_slop: float) -> None:
        self.space = pymunk.Space()
        self.space.collision_slop = collision_slop
        self.count = len(poses)
        moment = pymunk.moment_for_circle(BODY_MASS, 0.0, body_radius)
        self._inertia = np.array([BODY_MASS, BODY_MASS, moment])
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
        self._wrench = np.zeros((self.count + 1, 3))
        self.poses = np.array(poses, dtype=np.float64).reshape(-1, 3)
        self.twist = np.zeros((self.count, 3))  # (vx, vy, omega) after the last solve

    def step(self, linear: np.ndarray, angular: np.ndarray, dt: float) -> np.ndarray:
        """Drive every robot at (linear m/s, angular rad/s) for ``dt`` seconds; return poses."""
        if self.count == 0:
            return self.poses
        wrench = self._wrench[:self.count]
        heading = self.poses[:, 2]
        np.multiply(linear, np.cos(heading), out=wrench[:, 0])
        np.multiply(linear, np.sin(heading), out=wrench[:, 1])
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
        return self.poses
