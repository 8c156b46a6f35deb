"""Rigid-body physics of the Monas in the walled arena among its obstacles (pymunk).

Each Mona is a dynamic disc driven by the commanded linear and angular speed (differential
drive, no wheel slip modelled). The command is applied as the force that brings the body to
that velocity within the step, so pymunk's contact solver corrects it before positions move:
robots push each other and stop at walls instead of sinking in. (pymunk integrates positions
at the start of a step with the velocity the previous step's solver left, so a command moves
the robot one step later: a 32 ms actuation delay.) All bodies are read and written in one
batch call (a per-body Python loop costs about 5x), through pymunk's own batch functions in C
with their argument blocks built once per episode, and the wrench comes from one compiled
call; :class:`PhysicsBatch` computes the wrench of every robot of a batch of arenas in that
one call, into the arrays their spaces' write buffers are bound to, with the same numbers
in the same order as each space alone. Walls and obstacles (:mod:`swarm_world.arena`) are
static shapes of the space's static body, neither elastic nor rough.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numba
import numpy as np
import pymunk
import pymunk.batch
from pymunk._chipmunk_cffi import ffi, lib

from swarm_world.arena import Disc, Obstacle
from swarm_world.sensing.headings import heading_trig

BODY_MASS = 0.1  # kg; only the ratio between robots matters, and all are equal
WALL_THICKNESS = 0.05  # m, outside the arena so the inner faces sit exactly on its edges

_FIELDS = pymunk.batch.BodyFields
_STATE = _FIELDS.POSITION | _FIELDS.ANGLE | _FIELDS.VELOCITY | _FIELDS.ANGULAR_VELOCITY
_WRENCH = _FIELDS.FORCE | _FIELDS.TORQUE
# pymunk.batch.set_space_bodies / get_space_bodies call these iterators with a fresh argument
# block each time; Physics builds its blocks once and calls them directly.
_SET_BODY = ffi.addressof(lib, 'pmSpaceBodySetIteratorFuncBatched')
_GET_BODY = ffi.addressof(lib, 'pmSpaceBodyGetIteratorFuncBatched')
_each_body, _space_step = lib.cpSpaceEachBody, lib.cpSpaceStep


class Physics:
    """A pymunk space holding N robot discs inside four walls, among static obstacles.
    Rebuild it for every episode (pymunk's contact caches would otherwise make replays
    diverge)."""

    def __init__(self, arena_side: float, body_radius: float, poses: np.ndarray,
                 collision_slop: float, obstacles: Sequence[Obstacle] = ()) -> None:
        """Build the space.

        Args:
            arena_side: the side of the walled square (m).
            body_radius: every robot's (m).
            poses: [N, 3] the robots' initial (x, y, heading).
            collision_slop: the overlap pymunk allows between colliding shapes (m).
            obstacles: static shapes in the arena (after the walls, in the order given).
        """
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
        for obstacle in obstacles:
            solid = static_shape(self.space.static_body, obstacle)
            solid.elasticity = 0.0  # as the walls
            solid.friction = 0.0
            self.space.add(solid)
        self._read = pymunk.batch.Buffer()
        self._write = pymunk.batch.Buffer()
        # The space also lists its static body last: the buffers carry one spare row.
        self.bind(np.zeros((self.count + 1, 3)))  # the write buffer is _wrench's memory
        self._space = self.space._space  # the cpSpace pointer
        self._get = self._batched(_STATE, self._read)
        self._state: np.ndarray | None = None  # a view of the read buffer, once it exists
        self._scale = (0.0, self._inertia)  # (dt, [count, 3] inertia / dt) of the last step
        self._rows = np.arange(self.count, dtype=np.int64)  # wrench rows: its own array's
        self._stepped = False
        self.poses = np.array(poses, dtype=np.float64).reshape(-1, 3)
        self.twist = np.zeros((self.count, 3))  # (vx, vy, omega) after the last solve

    def __del__(self) -> None:
        # pymunk's bodies and shapes sit in reference cycles, so Python's cyclic collector frees
        # them, in whatever thread it runs (a Dask client's event loop, say), while the space
        # goes here, by reference count. A collection freeing a body while this thread freed
        # its space aborted the process (both edit the space's lists): the space is emptied
        # first, in the thread that drops it, so a body freed later touches no space.
        space = getattr(self, 'space', None)
        if space is not None:
            space.remove(*space.shapes, *space.bodies)

    @staticmethod
    def _batched(fields: pymunk.batch.BodyFields, buffer: pymunk.batch.Buffer) -> Any:
        """The argument block of pymunk's batched body iterators for ``buffer``."""
        data = ffi.new('pmBatchedData *')
        data.fields = fields.value
        data.floatArray = buffer._float_arr
        data.intArray = buffer._int_arr
        return data

    def bind(self, wrench: np.ndarray) -> None:
        """From now on write the wrench into ``wrench`` ([count + 1, 3] float64, C-contiguous:
        a block of a batch's array, see :class:`PhysicsBatch`) instead of its own array."""
        self._write.set_float_buf(wrench)
        self._wrench = wrench
        self._written = self._write._float_arr.num  # the floats it holds
        self._set = self._batched(_WRENCH, self._write)

    def step(self, linear: np.ndarray, angular: np.ndarray, dt: float) -> np.ndarray:
        """Drive every robot at (linear m/s, angular rad/s) for ``dt`` seconds; return poses."""
        if self.count == 0:
            return self.poses
        _wrench_kernel(np.asarray(linear, dtype=np.float64),
                       np.asarray(angular, dtype=np.float64), heading_trig(self.poses),
                       self.twist, self._rows, self._scale_for(dt), self._wrench)
        state = self.solve(dt)
        self.poses = state[:, :3].copy()
        self.twist = state[:, 3:].copy()
        return self.poses

    def _scale_for(self, dt: float) -> np.ndarray:
        """[count, 3]: (mass, mass, moment) / dt, the force that reaches a velocity in dt."""
        if self._scale[0] != dt:
            self._scale = (dt, np.tile(self._inertia / dt, (self.count, 1)))
        return self._scale[1]

    def solve(self, dt: float) -> np.ndarray:
        """Apply the wrench array to the bodies, step the space by ``dt`` and return the new
        state [count, 6] (x, y, angle, vx, vy, omega): a view of pymunk's read buffer, valid
        until the next step."""
        # pymunk.batch.set_space_bodies: read the buffer from its start, then restore it.
        space, written = self._space, self._write._float_arr
        written.num = 0
        _each_body(space, _SET_BODY, self._set)
        written.num = self._written
        if self._stepped:
            # Space.step's Python side (adds and removes queued in callbacks, post-step
            # callbacks, mass checks of new bodies) has nothing to do after the first step:
            # no callbacks are ever registered and no body is added or removed.
            _space_step(space, dt)
        else:
            self.space.step(dt)
            self._stepped = True
        read = self._read._float_arr
        read.num = 0  # Buffer.clear(); pymunk appends, growing the array only when full
        capacity = read.max
        _each_body(space, _GET_BODY, self._get)
        if self._state is None or read.max != capacity:  # first step, or the array moved
            self._state = np.frombuffer(self._read.float_buf(),
                                        dtype=np.float64).reshape(-1, 6)[:self.count]
        return self._state


def static_shape(body: pymunk.Body, obstacle: Obstacle) -> pymunk.Shape:
    """The pymunk shape of an obstacle on ``body`` (the space's static body): a circle, or
    the convex polygon of its vertices (a rect is one too)."""
    if isinstance(obstacle, Disc):
        return pymunk.Circle(body, obstacle.radius, offset=(obstacle.x, obstacle.y))
    return pymunk.Poly(body, list(obstacle.vertices))


@numba.njit(cache=True)
def _wrench_kernel(linear: np.ndarray, angular: np.ndarray, trig: np.ndarray, twist: np.ndarray,
                   rows: np.ndarray, scale: np.ndarray,
                   wrench: np.ndarray) -> None:  # pragma: no cover - jitted
    """Robot i's wrench into wrench[rows[i]]: the force and torque that take its velocity
    (twist) to the command (linear along its heading, whose cos and sin are trig[i], and
    angular) within one step."""
    for i in range(linear.shape[0]):
        row = rows[i]
        wrench[row, 0] = (linear[i] * trig[i, 0] - twist[i, 0]) * scale[i, 0]
        wrench[row, 1] = (linear[i] * trig[i, 1] - twist[i, 1]) * scale[i, 1]
        wrench[row, 2] = (angular[i] - twist[i, 2]) * scale[i, 2]


class PhysicsBatch:
    """The spaces of several arenas driven together: one compiled call computes every robot's
    wrench into one array (each space's write buffer is bound to its block), then each space
    is stepped alone by pymunk, and every robot's pose lands in one array. A space steps as it
    would alone: the same wrench, from the same operations, the same solver call."""

    def __init__(self, members: list[Physics]) -> None:
        self.members = members
        counts = [member.count for member in members]
        self.bounds = np.concatenate(([0], np.cumsum(counts))).astype(np.int64)
        # Each space's block has one spare row: pymunk also visits the static body.
        wrench = np.zeros((int(self.bounds[-1]) + len(members), 3))
        self._rows = np.concatenate([np.arange(count) + lo + e for e, (count, lo)
                                     in enumerate(zip(counts, self.bounds))]).astype(np.int64)
        for e, member in enumerate(members):
            lo, hi = int(self.bounds[e]) + e, int(self.bounds[e + 1]) + e + 1
            wrench[lo:hi] = member._wrench[:member.count + 1]
            member.bind(wrench[lo:hi])
        self._wrench = wrench
        self._live = [(member, slice(int(lo), int(hi))) for member, lo, hi
                      in zip(members, self.bounds[:-1], self.bounds[1:]) if member.count]
        self.poses = np.concatenate([member.poses for member in members])
        self.twist = np.concatenate([member.twist for member in members])
        self._scale: tuple[float, np.ndarray] = (0.0, np.zeros((0, 3)))

    def step(self, linear: np.ndarray, angular: np.ndarray, dt: float,
             trig: np.ndarray) -> np.ndarray:
        """Drive every robot of every space (rows in member order) for ``dt`` seconds; return
        the new poses [R, 3] (a new array; each member's ``poses`` is its rows of it).
        ``trig``: :func:`~swarm_world.sensing.headings.heading_trig` of the poses now."""
        if self._scale[0] != dt:
            self._scale = (dt, np.concatenate([member._scale_for(dt)
                                               for member in self.members]))
        _wrench_kernel(linear, angular, trig, self.twist, self._rows, self._scale[1],
                       self._wrench)
        poses, twist = np.empty_like(self.poses), self.twist
        for member, rows in self._live:
            state = member.solve(dt)
            poses[rows] = state[:, :3]
            twist[rows] = state[:, 3:]
            member.poses, member.twist = poses[rows], twist[rows]
        self.poses = poses
        return poses
