"""The batched engine: many independent episodes stepped together, each exactly as alone.

A step of one episode pays a fixed Python overhead for a few microseconds of model per
robot. :class:`Batch` pays it once for all its episodes: their worlds are stepped as one
:class:`~swarm_world.world.WorldBatch` (every robot's sensors and wheel forces in one compiled
call each; each world keeps its own pymunk space, cue and noise streams and is advanced by
the same parts as ``World.step``), and one controller (merged from the episodes' own,
:meth:`~mona_controller.controllers.Controller.merge`) steps all robots with per-robot
parameters and each robot's own random generator.

Exactness: every number an episode computes is computed from its own inputs by the same
operations as alone (element-wise arithmetic, the same compiled kernels on its own rows, the
same per-robot generators), so an episode's outputs are byte-identical to a lone run's for
any batch composition and order (tests/unit/test_batch.py). The episodes must share the step
and control periods (they step together), the number of IR beams (their readings are one
array) and the controller kind (one controller steps them); any other parameter may
differ. An episode that is done leaves the batch; the rest go on.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence

import numpy as np

from mona_controller.controllers import Command
from mona_controller.mona import wheels_to_twist
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import PARTS, Episode, Step
from swarm_world.timing import crossed
from swarm_world.world import Readings, WorldBatch


class BatchError(ValueError):
    """The episodes cannot be stepped together (other step or control periods, IR rings)."""


def batch_key(config: SwarmConfig) -> tuple[int, int, int, str]:
    """What episodes stepped together must share: the step period (ns), the control period
    (steps), the IR beams and the controller kind (one merged controller steps them)."""
    return (config.world.step_ns, config.world.control_steps, config.mona.ir_count,
            config.controller.kind)


@dataclasses.dataclass(frozen=True)
class _Twist:
    """Per-robot Mona geometry for :func:`wheels_to_twist` (it reads only these two)."""

    wheel_unit_speed: np.ndarray
    wheel_separation: np.ndarray


class Batch:
    """Episodes stepped together; each member is an ordinary :class:`Episode` (its world, its
    controllers' state, :meth:`Episode.metrics`), so observers and result collection treat it
    as a lone episode.

    Members must not be reset or stepped on their own while the batch steps them.
    """

    def __init__(self, episodes: Sequence[Episode], *, profile: bool = False) -> None:
        """Take over ``episodes`` (placed, not necessarily at t = 0).

        Args:
            profile: time each of :data:`~swarm_supervisor.engine.PARTS` of every step into
                :attr:`profile` (seconds summed over batch steps; same results).

        Raises:
            BatchError: the episodes differ in :func:`batch_key`.
        """
        self.members = list(episodes)
        keys = {batch_key(member.config) for member in self.members}
        if len(keys) > 1:
            raise BatchError('episodes stepped together must share the step and control periods, '
                             'the number of IR beams and the controller kind; got (step ns, '
                             f'control steps, beams, kind) {sorted(keys)}')
        #: Seconds spent in each of PARTS, summed over steps; None when not profiled.
        self.profile = dict.fromkeys(PARTS, 0.0) if profile else None
        self.active: list[Episode] = []
        self._regroup()

    @property
    def done(self) -> bool:
        """Whether every member has run its duration."""
        return not self.active

    def _regroup(self) -> None:
        """Concatenate the episodes still running: robot bounds, per-robot parameters, one
        merged controller (done once per change of membership, not per step)."""
        self.active = [member for member in self.members if not member.done]
        if not self.active:
            return
        # Steps until the first running episode is done: the membership changes no sooner,
        # so a step need not ask every member (K members, every step) whether it is done.
        self._steps_left = min(member.steps_total - member.steps_done
                               for member in self.active)
        self.worlds = WorldBatch([member.world for member in self.active])
        self._slices = self.worlds.slices
        self._counts = np.diff(self.worlds.bounds)
        monas = [member.world.mona for member in self.active]
        self._twist = _Twist(
            np.repeat([mona.wheel_unit_speed for mona in monas], self._counts),
            np.repeat([mona.wheel_separation for mona in monas], self._counts))
        parts = [member.controllers for member in self.active]
        self.controller = type(parts[0]).merge(parts)
        self._control_steps = self.active[0].control_steps
        # The answer the wheels hold between control steps: each running member's latest.
        self._held = Command(np.concatenate([member.command.wheels for member in self.active]),
                             np.concatenate([member.command.cleaner for member in self.active]))

    def sense(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every running robot's readings now, episode after episode: (ground [R, 2] uint8,
        ranges [R, K] float32, is_robot [R, K]); each episode's rows equal its
        ``World.sense()``."""
        return self.worlds.sense()

    def readings(self) -> list[Readings]:
        """:meth:`sense` split into each running episode's :class:`Readings` (for tests)."""
        ground, ranges, is_robot = self.sense()
        return [Readings(member.world.time_ns, ground[rows], ranges[rows], is_robot[rows])
                for member, rows in zip(self.active, self._slices)]

    def step(self) -> list[tuple[Episode, Step]]:
        """Step every running episode once; return each one's (episode, step), in member
        order. Episodes that are done after it leave the batch."""
        if self.profile is not None:
            return self._profiled_step()
        if self.active[0].steps_done % self._control_steps == 0:  # members step together
            ground, ranges, is_robot = self.sense()
            self._held = self.controller.step(ground, ranges, is_robot, self._now())
        return self.drive(self._held)

    def _now(self) -> np.ndarray:
        """Each running robot's sim time (s): its episode's ``time_ns / 1e9``."""
        return np.repeat([member.world.time_ns / 1e9 for member in self.active],
                         self._counts)

    def drive(self, command: Command) -> list[tuple[Episode, Step]]:
        """Drive every running robot's wheels with ``command`` (rows as :meth:`sense`) and
        step every running episode once, without asking the controllers; as :meth:`step`,
        episodes that are done after it leave the batch."""
        linear, angular = wheels_to_twist(command.wheels, self._twist)
        before = [member.world.time_ns for member in self.active]
        self.worlds.step(linear, angular, command.cleaner)
        steps = []
        for member, rows, start in zip(self.active, self._slices, before):
            world = member.world
            member.command = Command(command.wheels[rows], command.cleaner[rows])
            steps.append((member, Step(
                start, world.time_ns, crossed(start, world.time_ns, member.sample_ns),
                world.cleaned, member.command)))
        self._steps_left -= 1
        if self._steps_left <= 0:
            self._regroup()
        return steps

    def _profiled_step(self) -> list[tuple[Episode, Step]]:
        spent, clock = self.profile, time.perf_counter
        assert spent is not None, 'profiled steps run only with profile=True'
        t0 = t1 = t2 = t3 = clock()
        if self.active[0].steps_done % self._control_steps == 0:
            ground = self.worlds.ground()
            t1 = clock()
            ranges, is_robot = self.worlds.proximity()
            t2 = clock()
            self._held = self.controller.step(ground, ranges, is_robot, self._now())
            t3 = clock()
        steps = self.drive(self._held)
        t4 = clock()
        spent['ground sensors'] += t1 - t0
        spent['IR sensors'] += t2 - t1
        spent['controller'] += t3 - t2
        spent['physics+cleaning'] += t4 - t3
        return steps
