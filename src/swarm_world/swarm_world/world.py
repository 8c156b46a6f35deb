"""The world engine: arena, cue, physics and sensors behind a reset / sense / step contract.

Both runners drive this one class: the embedded runner calls it directly, the world node wraps
it. Sim time is kept in integer nanoseconds so that a time carried by a ROS stamp converts back
exactly; ``now = time_ns / 1e9`` is the one conversion every component uses.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mona_controller.mona import MonaParams
from swarm_world import cue as cue_field
from swarm_world.arena import pack
from swarm_world.company import in_company
from swarm_world.field import CueField
from swarm_world.params import WorldParams
from swarm_world.physics import Physics, PhysicsBatch
from swarm_world.sensing import noise
from swarm_world.sensing.delay import CommandDelay
from swarm_world.sensing.ground import (
    NO_NOISE,
    field_list,
    ground_kernel,
    ground_many_kernel,
    sensor_geometry,
    set_field,
)
from swarm_world.sensing.headings import heading_trig
from swarm_world.sensing.ir import proximity, proximity_many
from swarm_world.sensing.params import SensingParams
from swarm_world.sensing.transfer import transfer_table
from swarm_world.timing import crossed

#: No robot (what ``World.cleaned`` holds after a step without cleaning); read-only, shared.
_NOBODY = np.zeros(0, dtype=np.int64)
_NOBODY.setflags(write=False)


@dataclasses.dataclass
class Readings:
    """What every robot senses at one instant (a Mona driver publishes the same)."""

    time_ns: int  #: sim time of the readings
    ground: np.ndarray  #: [N, 2] uint8, left and right ground sensors
    ranges: np.ndarray  #: [N, K] float32, IR ranges from the body edge (m), inf = nothing
    is_robot: np.ndarray  #: [N, K] bool, the obstacle seen is a robot

    @property
    def now(self) -> float:
        """Sim time in seconds."""
        return self.time_ns / 1e9


class World:
    """N Monas in the walled arena, among its obstacles, on the cue field."""

    def __init__(self, params: WorldParams, mona: MonaParams, sensing: SensingParams) -> None:
        self.params = params
        self.mona = mona
        self.sensing = sensing
        self.arena = params.arena()  #: the walls and the obstacles
        self.bearings = mona.ir_bearings()
        self.field = CueField(params, mona, sensing)
        self._step_ns = params.step_ns
        self._cleaning_ns = round(params.cleaning_period * 1e9)
        self.footprint = cue_field.footprint_cells(sensing.ground_footprint, params.cell_size)
        #: The ground sensors: where they sit (ground.sensor_geometry) and what they read on
        #: a cue value (transfer.transfer_table; empty: the value itself).
        self.sensor_geometry = sensor_geometry(mona, sensing)
        self.transfer = transfer_table(sensing)
        self._sensed: np.ndarray | None = None  # the cue as the ground sensors see it
        self.noise = noise.NoiseLevels(ground=sensing.ground_noise, ir_miss=sensing.ir_miss,
                                       wheel=sensing.wheel_noise)
        self.seed = 0  # the episode seed: the noise streams derive from it
        #: World steps between a command and the wheels (sensing.command_latency control
        #: steps).
        self.latency_steps = sensing.command_latency * params.control_steps
        self.delay: CommandDelay | None = None  # the episode's delay line (None: no latency)
        self.physics = self._physics(np.zeros((0, 3)))
        self.time_ns = 0
        self.steps = 0
        self.cleaning = np.zeros(0, dtype=bool)
        self.cleaned = _NOBODY  # robots that cleaned in the last step

    @property
    def cue(self) -> np.ndarray:
        """The cue raster now (float32 [rows, cols], row = y cell)."""
        return self.field.cue

    @property
    def initial_cue(self) -> np.ndarray:
        """The cue at t = 0 (read-only)."""
        return self.field.initial

    @property
    def initial_mean_cue(self) -> float:
        """The arena mean of the initial cue (cue units)."""
        return self.field.initial_mean

    @property
    def population(self) -> int:
        """The number of robots in the current episode."""
        return self.physics.count

    @property
    def poses(self) -> np.ndarray:
        """[N, 3] float64 (x m, y m, heading rad) in the world frame."""
        return self.physics.poses

    @property
    def now(self) -> float:
        """Sim time in seconds."""
        return self.time_ns / 1e9

    def reset(self, poses: np.ndarray, seed: int = 0) -> None:
        """Start an episode: restore the cue, rebuild the physics with robots at ``poses``;
        the sensor and wheel noise (if any) derive from ``seed``."""
        poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
        self.seed = int(seed)
        self.field.reset()
        self._sensed = None
        self.physics = self._physics(poses)
        self.delay = CommandDelay(self.latency_steps, len(poses)) if self.latency_steps else None
        self.time_ns = 0
        self.steps = 0
        self.cleaning = np.zeros(len(poses), dtype=bool)
        self.cleaned = _NOBODY

    def warm_up(self) -> None:
        """Step two robots, cleaning, for one cleaning and transport period, then forget it
        all: numba loads every kernel of a step now (on a fresh install it compiles them,
        seconds of CPU) rather than in an episode's first step, where the stall would look
        like a lost world to a node's recorders. It ends as it began: no robots, the
        initial cue."""
        side = self.params.arena_side
        self.reset(np.array([[0.3 * side, 0.5 * side, 0.0], [0.7 * side, 0.5 * side, 0.0]]))
        period = max(self.params.cleaning_period, self.params.transport_period)
        for _ in range(round(period * 1e9) // self._step_ns + 1):
            self.sense()
            self.step(np.zeros(2), np.zeros(2), np.ones(2, dtype=bool))
        self.reset(np.zeros((0, 3)))

    def _physics(self, poses: np.ndarray) -> Physics:
        return Physics(self.params.arena_side, self.mona.body_radius, poses,
                       self.params.collision_slop, self.arena.obstacles)

    def sensed_field(self) -> np.ndarray:
        """The cue as the ground sensors see it (each cell the mean over a sensor's footprint);
        cached until the cue changes. A batched engine senses many worlds through this."""
        if self._sensed is None:
            self._sensed = cue_field.sensed_field(self.cue, self.footprint)
        return self._sensed

    def sense(self) -> Readings:
        """Every robot's readings at the current time."""
        ground = self.ground_readings()
        ranges, is_robot = self.ir_readings()
        return Readings(self.time_ns, ground, ranges, is_robot)

    def ground_readings(self) -> np.ndarray:
        """Every robot's ground readings now: [N, 2] uint8 (left, right), with this step's
        sensor noise if any (the ground half of :meth:`sense`)."""
        poses = self.poses
        return self.ground(poses, np.empty((len(poses), 2), dtype=np.uint8))

    def ir_readings(self) -> tuple[np.ndarray, np.ndarray]:
        """Every robot's IR ranges [N, K] float32 and robot flags [N, K] now, with this step's
        missed beams if any (the IR half of :meth:`sense`)."""
        poses = self.poses
        ranges, is_robot = proximity(poses, self.mona.body_radius, self.bearings,
                                     self.mona.ir_range, self.params.arena_side,
                                     self.arena.packed)
        if self.perceives:
            self.perceive(ranges, is_robot, poses)
        return ranges, is_robot

    @property
    def perceives(self) -> bool:
        """Whether :meth:`perceive` changes anything (else the beams are the geometry's)."""
        sensing = self.sensing
        return (sensing.ir_robot_factor < 1.0 or bool(self.noise.ir_miss)
                or sensing.robot_detection == 'position')

    def perceive(self, ranges: np.ndarray, is_robot: np.ndarray, poses: np.ndarray) -> None:
        """In place, what this world's robots make of their beams beyond the geometry: a
        robot body is seen only within ``ir_range x ir_robot_factor`` (farther, the beam it
        stops sees nothing), this step's missed beams drop out (``ir_miss``), and with
        ``robot_detection: position`` whatever a beam sees is a wall when the robot's centre
        is within ``wall_margin`` of a wall or an obstacle, else a robot."""
        mona, sensing = self.mona, self.sensing
        if sensing.ir_robot_factor < 1.0:
            far = is_robot & (ranges > mona.ir_range * sensing.ir_robot_factor)
            ranges[far] = np.inf
            is_robot[far] = False
        if self.noise.ir_miss:
            self.miss_beams(ranges, is_robot)
        if sensing.robot_detection == 'position':
            near = self.clearance(poses) < sensing.wall_margin
            is_robot[:] = (ranges < np.inf) & ~near[:, None]

    def clearance(self, poses: np.ndarray) -> np.ndarray:
        """[N] how far each robot's centre is from the nearest wall or obstacle (m)."""
        x, y, side = poses[:, 0], poses[:, 1], self.params.arena_side
        walls: np.ndarray = np.minimum(np.minimum(x, y), np.minimum(side - x, side - y))
        if not self.arena.obstacles:
            return walls
        return np.array([self.arena.clearance(px, py) for px, py in poses[:, :2].tolist()])

    def ground(self, poses: np.ndarray, out: np.ndarray) -> np.ndarray:
        """The ground readings of robots at ``poses`` (this world's robots, now) into ``out``
        [N, 2] uint8, with this step's sensor noise if any."""
        extra = self.ground_noise() if self.noise.ground else NO_NOISE
        return ground_kernel(self.sensed_field(), self.params.cell_size, poses,
                             heading_trig(poses), self.sensor_geometry, self.transfer, extra,
                             out)

    def ground_noise(self) -> np.ndarray:
        """[N, 2] this step's ground-sensor noise (cue units): the world's counter-based
        stream, the same in any runner."""
        return self.noise.ground * noise.normals(self.seed, noise.GROUND_STREAM,
                                                 np.arange(self.population), self.steps, 2)

    def miss_beams(self, ranges: np.ndarray, is_robot: np.ndarray) -> None:
        """Drop this step's missed IR beams (noise ``ir_miss``) from this world's readings."""
        missed = noise.uniforms(self.seed, noise.IR_STREAM, np.arange(len(ranges)),
                                self.steps, ranges.shape[1]) < self.noise.ir_miss
        ranges[missed] = np.inf
        is_robot[missed] = False

    def step(self, linear: np.ndarray, angular: np.ndarray, cleaner: np.ndarray) -> None:
        """Advance one step with these commands; clean on each cleaning-period boundary.
        With ``sensing.command_latency`` the commands drive a later step (:meth:`delayed`).

        Args:
            linear: [N] forward speeds (m/s).
            angular: [N] turn rates (rad/s, counter-clockwise).
            cleaner: [N] bool, the cleaning actuators.
        """
        linear, angular, cleaner = self.delayed(linear, angular, cleaner)
        linear, angular = self.wheels(np.asarray(linear, dtype=np.float64),
                                      np.asarray(angular, dtype=np.float64))
        self.physics.step(linear, angular, self.params.step_period)
        self.moved(cleaner)

    def delayed(self, linear: np.ndarray, angular: np.ndarray,
                cleaner: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The commands that reach the wheels and the cleaner at this step: these ones
        without latency, else those given ``latency_steps`` steps ago (a stop before the
        first). Called once per step, by :meth:`step` or the batch."""
        if self.delay is None:
            return linear, angular, cleaner
        return self.delay.shift(linear, angular, cleaner)

    def wheels(self, linear: np.ndarray, angular: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The speeds the wheels deliver for the commanded (linear, angular): with wheel noise,
        each wheel's error of this step added; without, the command itself."""
        if not self.noise.wheel or not self.population:
            return linear, angular
        error = self.noise.wheel * noise.normals(self.seed, noise.WHEEL_STREAM,
                                                 np.arange(self.population), self.steps, 2)
        return noise.noisy_wheels(linear, angular, self.mona.wheel_separation, error)

    def moved(self, cleaner: np.ndarray) -> None:
        """The rest of a step, once the physics has moved the robots: the clock advances,
        robots clean on a cleaning-period boundary (eq. 3), the cue's transport runs."""
        self.cleaning = cleaning = np.asarray(cleaner, dtype=bool)
        before = self.time_ns
        self.steps += 1
        self.time_ns = now = self.steps * self._step_ns
        self.cleaned = _NOBODY
        if crossed(before, now, self._cleaning_ns) and cleaning.any():
            self.cleaned = np.flatnonzero(cleaning)
            if self.params.cleaning_quorum > 1:  # only robots in a group clean (company.py)
                self.cleaned = in_company(self.cleaned, self.poses,
                                          self.params.cleaning_quorum,
                                          self.params.cleaning_range)
            if len(self.cleaned):
                self.field.clean_at(now, self.poses[self.cleaned])  # eq. 3, robot order
                self._sensed = None
        # A static field has no transport ticks: skip the call (a batch pays it per world).
        if self.field.dynamic and self.field.advance_to(now):
            self._sensed = None  # diffusion, evaporation, emission changed the cue


class WorldBatch:
    """Several worlds stepped as one (the batched engine's world side): their robots' poses in
    one array, the IR ring of all of them cast in one compiled call, their physics driven by
    one :class:`PhysicsBatch`. Each world's readings and motion are those of its own
    :meth:`World.sense` and :meth:`World.step`: the same kernels on its own rows, its own
    noise streams, its own space, field and clock.

    The worlds must share the step period and the number of IR beams; they must not be reset
    or stepped on their own while the batch steps them.
    """

    def __init__(self, worlds: list[World]) -> None:
        self.worlds = worlds
        counts = np.array([world.population for world in worlds], dtype=np.int64)
        self.bounds = np.concatenate(([0], np.cumsum(counts)))
        self.slices = [slice(int(lo), int(hi))
                       for lo, hi in zip(self.bounds[:-1], self.bounds[1:])]
        self.physics = PhysicsBatch([world.physics for world in worlds])
        self._step_period = worlds[0].params.step_period if worlds else 0.0
        monas = [world.mona for world in worlds]
        self._ir = (np.array([mona.body_radius for mona in monas]),
                    np.array([world.bearings for world in worlds]),
                    np.array([mona.ir_range for mona in monas]),
                    np.array([world.params.arena_side for world in worlds]),
                    pack([world.arena for world in worlds]))
        # The worlds whose commands reach the wheels late (sensing.command_latency), with rows.
        self._delayed = [(world, rows) for world, rows in zip(worlds, self.slices)
                         if world.delay is not None]
        # The worlds with each kind of noise (usually none), with their rows.
        self._noisy_wheels, self._noisy_ground = (
            [(world, rows) for world, rows in zip(worlds, self.slices)
             if getattr(world.noise, kind)] for kind in ('wheel', 'ground'))
        # The worlds whose robots make more of their beams than the geometry (World.perceive).
        self._perceiving = [(world, rows) for world, rows in zip(worlds, self.slices)
                            if world.perceives]
        self._ground_noisy = np.array([bool(world.noise.ground) for world in worlds])
        self._trig: tuple[np.ndarray | None, np.ndarray] = (None, np.zeros((0, 2)))
        knots = max((len(world.transfer) for world in worlds), default=0)
        tables = np.zeros((len(worlds), knots))
        for row, world in zip(tables, worlds):
            row[:len(world.transfer)] = world.transfer
        self._ground = (np.array([world.params.cell_size for world in worlds]),
                        np.array([world.sensor_geometry for world in worlds]).reshape(-1, 2),
                        tables, np.array([len(world.transfer) > 0 for world in worlds]))
        # Each world's sensed field, in one list the compiled kernel takes, replaced when the
        # world's is a new array (a typed list returns new wrappers: compare the plain list's).
        self._field_list = [world.sensed_field() for world in worlds]
        self._fields = field_list(self._field_list) if worlds else None

    @property
    def poses(self) -> np.ndarray:
        """[R, 3] every robot's pose, world after world."""
        return self.physics.poses

    def trig(self) -> np.ndarray:
        """[R, 2] :func:`heading_trig` of :attr:`poses`: worked out once per step for the
        ground sensors, the IR ring and the wheels' force."""
        poses = self.physics.poses
        if self._trig[0] is not poses:
            self._trig = (poses, heading_trig(poses))
        return self._trig[1]

    def sense(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every robot's readings now, world after world: (ground [R, 2] uint8, ranges
        [R, K] float32, is_robot [R, K]); each world's rows equal its :meth:`World.sense`."""
        return (self.ground(), *self.proximity())

    def ground(self) -> np.ndarray:
        """:meth:`sense`'s ground readings."""
        for e, world in enumerate(self.worlds):
            field = world.sensed_field()
            if field is not self._field_list[e]:  # a new array (footprint, transport)
                self._field_list[e] = field
                set_field(self._fields, e, field)
        extra = NO_NOISE
        if self._noisy_ground:
            extra = np.zeros((int(self.bounds[-1]), 2))
            for world, rows in self._noisy_ground:
                extra[rows] = world.ground_noise()
        return ground_many_kernel(self._fields, self.bounds, *self._ground, self.poses,
                                   self.trig(), extra, self._ground_noisy,
                                   np.empty((int(self.bounds[-1]), 2), dtype=np.uint8))

    def proximity(self) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`sense`'s IR readings (ranges, is_robot)."""
        ranges, is_robot = proximity_many(self.poses, self.trig(), self.bounds, *self._ir)
        poses = self.poses
        for world, rows in self._perceiving:
            world.perceive(ranges[rows], is_robot[rows], poses[rows])
        return ranges, is_robot

    def step(self, linear: np.ndarray, angular: np.ndarray, cleaner: np.ndarray) -> None:
        """Step every world once: robot rows as in :meth:`sense`, arguments as
        :meth:`World.step`'s."""
        if self._delayed:
            linear, angular, cleaner = linear.copy(), angular.copy(), cleaner.copy()
            for world, rows in self._delayed:
                linear[rows], angular[rows], cleaner[rows] = world.delayed(
                    linear[rows], angular[rows], cleaner[rows])
        if self._noisy_wheels:
            linear, angular = linear.copy(), angular.copy()
            for world, rows in self._noisy_wheels:
                linear[rows], angular[rows] = world.wheels(linear[rows], angular[rows])
        self.physics.step(linear, angular, self._step_period, self.trig())
        for world, rows in zip(self.worlds, self.slices):
            world.moved(cleaner[rows])
