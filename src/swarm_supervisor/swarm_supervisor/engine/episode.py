"""The episode engine: placement, then sense -> controllers -> wheels -> world, step by step.

The one loop of the model in one process. The embedded runner, the tests and the benchmarks
drive :class:`Episode`; the ROS nodes run the same parts over topics. Pure (no ROS).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from mona_controller.controllers import Command, make_controller
from mona_controller.mona import wheels_to_twist
from swarm_metrics.metrics import sample_field
from swarm_supervisor.config import SwarmConfig
from swarm_world.placement import place_robots, placement_rng
from swarm_world.timing import crossed
from swarm_world.world import World

#: The parts of a step that a profiled episode times (see ``Episode(profile=True)``).
PARTS = ('ground sensors', 'IR sensors', 'controller', 'physics+cleaning')


def place_swarm(config: SwarmConfig, seed: int) -> np.ndarray:
    """The initial poses [N, 3] of an episode of ``config`` with this seed.

    Raises:
        PlacementError: the population does not fit in the arena.
    """
    return place_robots(config.episode.population, config.world.arena_side,
                        config.mona.body_radius, placement_rng(seed),
                        obstacles=config.world.arena().obstacles)


@dataclasses.dataclass(slots=True)
class Step:
    """What one step did."""

    before_ns: int  #: sim time before the step
    time_ns: int  #: sim time after the step
    sampled: bool  #: it crossed a metrics sample boundary: a metrics row is due now
    cleaned: np.ndarray  #: indices of the robots that cleaned in this step (usually none)
    command: Command  #: the controllers' answer that drove the step


class Episode:
    """One episode of ``config``: N Monas, their controllers and the world, in one process.

    Ready to step once built (placed from ``config.episode.seed``); :meth:`reset` starts over,
    from another seed if given. Sim time is the world's integer nanoseconds.
    """

    def __init__(self, config: SwarmConfig, *, profile: bool = False) -> None:
        """Build the world and the controllers and reset them.

        Args:
            profile: time each of :data:`PARTS` of every step into :attr:`profile` (the
                benchmark's split; a little slower, same results).
        """
        self.config = config
        self.world = World(config.world, config.mona, config.sensing)
        self.controllers = make_controller(config.controller, config.mona,
                                           range(config.episode.population))
        self.steps_total = config.steps()
        self.sample_ns = round(config.metrics.sample_period * 1e9)
        self.control_steps = config.world.control_steps
        #: The controllers' latest answer (held between control steps).
        self.command = Command(np.zeros((config.episode.population, 2)),
                               np.zeros(config.episode.population, dtype=bool))
        #: Seconds spent in each of :data:`PARTS`, summed over steps; None when not profiled.
        self.profile = dict.fromkeys(PARTS, 0.0) if profile else None
        self.seed = config.episode.seed
        self.initial_poses = np.zeros((0, 3))
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        """Start over: place the robots from ``seed`` (default ``config.episode.seed``), restore
        the cue, reseed every controller.

        Raises:
            PlacementError: the population does not fit in the arena.
        """
        self.seed = self.config.episode.seed if seed is None else seed
        self.world.reset(place_swarm(self.config, self.seed), self.seed)
        self.controllers.reset(self.seed)
        self.initial_poses = self.world.poses.copy()
        if self.profile is not None:
            self.profile = dict.fromkeys(PARTS, 0.0)

    @property
    def time_ns(self) -> int:
        """Sim time (ns) since the episode started."""
        return self.world.time_ns

    @property
    def now(self) -> float:
        """Sim time in seconds."""
        return self.world.time_ns / 1e9

    @property
    def steps_done(self) -> int:
        """Steps taken since the last reset."""
        return self.world.steps

    @property
    def done(self) -> bool:
        """Whether the episode has run its duration (``steps_total`` steps)."""
        return self.world.steps >= self.steps_total

    def step(self) -> Step:
        """Sense, let every controller answer, drive the wheels and advance the world one step.

        With ``world.control_steps`` k > 1 the controllers answer (and the robots sense) only
        at every k-th step; the wheels and the cleaner hold that answer in between.
        Stepping past :attr:`done` carries on (the caller decides when to stop).
        """
        if self.profile is not None:
            return self._profiled_step()
        world = self.world
        if world.steps % self.control_steps == 0:
            readings = world.sense()
            self.command = self.controllers.step(readings.ground, readings.ranges,
                                                 readings.is_robot, readings.now)
        return self.drive(self.command)

    def drive(self, command: Command) -> Step:
        """Drive the wheels with ``command`` and step the world once, without asking the
        controllers (:meth:`step` asks them, then drives; a learning environment drives with
        its agents' actions, :mod:`swarm_supervisor.envs`)."""
        world = self.world
        linear, angular = wheels_to_twist(command.wheels, self.config.mona)
        before = world.time_ns
        world.step(linear, angular, command.cleaner)
        return Step(before, world.time_ns, crossed(before, world.time_ns, self.sample_ns),
                    world.cleaned, command)

    def _profiled_step(self) -> Step:
        """:meth:`step` with its parts timed, from the same calls ``World.sense`` makes (the
        ground half, then the IR half), so the trajectory is the same."""
        world, spent, clock = self.world, self.profile, time.perf_counter
        assert spent is not None, 'profiled steps run only with profile=True'
        t0 = t1 = t2 = t3 = clock()
        if world.steps % self.control_steps == 0:
            ground = world.ground_readings()
            t1 = clock()
            ranges, is_robot = world.ir_readings()
            t2 = clock()
            self.command = self.controllers.step(ground, ranges, is_robot, world.now)
            t3 = clock()
        step = self.drive(self.command)
        t4 = clock()
        spent['ground sensors'] += t1 - t0
        spent['IR sensors'] += t2 - t1
        spent['controller'] += t3 - t2
        spent['physics+cleaning'] += t4 - t3
        return step

    def metrics(self) -> dict[str, float]:
        """The metrics row of the current state, stamped with the last sample boundary's time
        (what the runner records at t = 0 and after each step with ``sampled``)."""
        world = self.world
        t = world.time_ns // self.sample_ns * self.config.metrics.sample_period
        return sample_field(t, world.field, world.poses[:, :2], self.config.metrics)
