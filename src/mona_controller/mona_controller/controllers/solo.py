"""The ``solo`` controller: the plain solitary rule BEECLUST is measured against. Stand and
clean where the cue is strong, alone; otherwise follow the gradient and keep off walls and
robots.

A robot follows the gradient as BEECLUST does (eq. 2 at ``controller.speed``, with
``controller.solo.alpha``). Where its mean reading S = (s_l + s_r) / 2 is at least
``clean_above`` it stops and cleans, whether or not another robot is there, for as long as
S stays at or above ``clean_above``: its own cleaning lowers the reading, so it moves on
once the floor under it is clean. A stand lasts at most ``stand_max`` seconds (a leaking
source would hold a robot for ever): then the robot turns in place by theta ~ U[turn_min,
turn_max] in a random direction, as BEECLUST does after a wait, and drives ``leave``
seconds before it may stand again. Anything its beams see, a wall or a robot, it turns
away from in place (BEECLUST's ``turn-away`` at a wall) until no beam sees it: robots are
obstacles to it, never a reason to stop.

So BEECLUST and ``solo`` differ in what makes a robot stop and clean, and for how long:
meeting a robot, for eq. 1's wait (BEECLUST), or a strong cue, for as long as it lasts
(solo). ``controller.kind: [beeclust, solo]`` is then one factor of a study. The random
turn after a full stand draws from the robot's own generator, ``default_rng([seed,
CONTROLLER_STREAM, robot id])``, as BEECLUST's; :class:`Longhand` writes the rules out for
one robot in plain Python and tests/unit/test_solo.py holds the fast controller to it bit
for bit.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from mona_controller.controllers.base import Command, Controller, State
from mona_controller.controllers.beeclust import CONTROLLER_STREAM, gradient_wheels
from mona_controller.controllers.params import ControllerParams
from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError, param, validate

#: Behaviour states, by code (BEECLUST's codes and colours for its like states): following
#: the gradient green, turning away from an obstacle orange, standing (and cleaning) red,
#: turning after a full stand blue.
FOLLOW, AVOID, STAND, TURN = 0, 1, 2, 3
STATES = (State('follow', (0.20, 0.75, 0.25, 1.0)), State('avoid', (1.00, 0.60, 0.00, 1.0)),
          State('stand', (0.90, 0.10, 0.10, 1.0)), State('turn', (0.25, 0.45, 1.00, 1.0)))


@dataclasses.dataclass(frozen=True)
class SoloParams:
    """The solo controller's parameters, ``controller.solo.*`` (docs/learned.md)."""

    alpha: float = param(2.0, unit='cue units per wheel unit', low=0.01, high=1e6,
                         doc="gradient gain divisor of eq. 2 (BEECLUST's)")
    clean_above: float = param(30.0, unit='cue units', low=0.0, high=255.0,
                               doc='stand and clean while the mean ground reading is at '
                                   'least this')
    stand_max: float = param(30.0, unit='s', low=0.0, high=3600.0,
                             doc="the longest stand (BEECLUST's wait_max); then turn and "
                                 'drive on')
    leave: float = param(10.0, unit='s', low=0.0, high=3600.0,
                         doc='after a stand of stand_max, the seconds a robot drives before '
                             'it may stand again')
    turn_min: float = param(math.pi / 2, unit='rad', low=0.0, high=2 * math.pi,
                            doc='smallest turn after a full stand (90 deg)')
    turn_max: float = param(math.pi, unit='rad', low=0.0, high=2 * math.pi,
                            doc='largest turn after a full stand (180 deg)')
    turn_speed: float = param(0.04, unit='m/s', low=0.001, high=1.0,
                              doc='wheel speed while turning in place')

    def __post_init__(self) -> None:
        validate(self, 'controller.solo.')
        if self.turn_min > self.turn_max:
            raise ParameterError(f'controller.solo.turn_min = {self.turn_min} must not '
                                 f'exceed controller.solo.turn_max = {self.turn_max}')


def constants(params: ControllerParams, mona: MonaParams) -> tuple[float, float, float]:
    """beta (eq. 2's command on a clean floor), the in-place turn's wheel command and the
    turn rate it gives (rad/s).

    Raises:
        ParameterError: ``controller.speed`` needs more than the wheels' top command.
    """
    own = params.section(SoloParams)
    beta = params.speed / mona.wheel_unit_speed
    if beta > mona.max_wheel_command:
        raise ParameterError(f'controller.speed = {params.speed} is out of range for the '
                             f'solo kind: at most {mona.max_wheel_command:g} wheel units')
    spin = min(own.turn_speed / mona.wheel_unit_speed, mona.max_wheel_command)
    return beta, spin, 2 * spin * mona.wheel_unit_speed / mona.wheel_separation


def turn_away(seen: Sequence[bool], bearings: Sequence[float]) -> float:
    """The direction (+1 counter-clockwise, -1 clockwise) away from what the beams see: the
    sign of the sum of their bearings (> 0 on the left), added from the right; straight
    ahead only: counter-clockwise (BEECLUST's rule at a wall)."""
    side = 0.0
    for sees, bearing in zip(seen, bearings):
        if sees:
            side += bearing
    return -1.0 if side > 0 else 1.0


class Longhand:
    """One robot's solo rules in plain Python, in the order they apply."""

    def __init__(self, params: ControllerParams, mona: MonaParams, robot_id: int,
                 seed: int) -> None:
        self.own = params.section(SoloParams)
        self.mona = mona
        self.beta, self.spin, self.rate = constants(params, mona)
        self.bearings = mona.ir_bearings().tolist()
        self.state, self.until, self.calm, self.direction = FOLLOW, 0.0, 0.0, 1.0
        self.rng = np.random.default_rng([seed, CONTROLLER_STREAM, robot_id])

    def step(self, ground: Sequence[int], ranges: Sequence[float], is_robot: Sequence[bool],
             now: float) -> tuple[tuple[float, float], bool]:
        """The wheels and the cleaner for these readings at ``now`` (s)."""
        left, right = int(ground[0]), int(ground[1])
        level = (left + right) / 2
        seen = [float(r) < math.inf for r in ranges]
        if self.state == STAND:
            if now >= self.until:  # a full stand: turn away, then leave
                angle = self.rng.uniform(self.own.turn_min, self.own.turn_max)
                self.direction = 1.0 if self.rng.random() < 0.5 else -1.0
                self.state, self.until = TURN, now + angle / self.rate
                self.calm = self.until + self.own.leave
            elif level < self.own.clean_above:
                self.state = FOLLOW
        elif self.state == TURN and now >= self.until:
            self.state = FOLLOW
        if self.state == AVOID and not any(seen):
            self.state = FOLLOW
        if self.state in (FOLLOW, AVOID) and level >= self.own.clean_above and \
                now >= self.calm:
            self.state, self.until = STAND, now + self.own.stand_max
        if self.state == FOLLOW and any(seen):
            self.state, self.direction = AVOID, turn_away(seen, self.bearings)
        if self.state == STAND:
            return (0.0, 0.0), True
        if self.state == FOLLOW:
            top = self.mona.max_wheel_command
            wheel_left = (right - left) / self.own.alpha + self.beta
            wheel_right = (left - right) / self.own.alpha + self.beta
            return (min(max(wheel_left, 0.0), top), min(max(wheel_right, 0.0), top)), False
        spin = self.direction * self.spin
        return (-spin, spin), False


class SoloController(Controller):
    """The solo controllers of the robots ``robot_ids`` (the ``solo`` kind).

    Vectorised: each rule is a few array operations over all robots, in :class:`Longhand`'s
    order, and the robots that turn (a few a step) are handled one by one. Every parameter
    is held per robot, so that :meth:`merge` can join controllers of several episodes with
    their own parameters. ``encounters`` stays 0 (meetings do not matter to it).
    """

    STATES = STATES
    Params = SoloParams
    PER_ROBOT = (*Controller.PER_ROBOT, 'until', 'calm', 'direction', 'rngs')

    def __init__(self, params: ControllerParams, mona: MonaParams,
                 robot_ids: Sequence[int]) -> None:
        """The robots ``robot_ids``, reset with seed 0.

        Raises:
            ParameterError: the speed needs more than the wheels' top command.
        """
        super().__init__(params, mona, robot_ids)
        n = len(self.robot_ids)
        self.until = np.zeros(n)  # the end (s) of the current stand or turn
        self.calm = np.zeros(n)  # no stand before this (s): leaving after a full stand
        self.direction = np.ones(n)  # +1 counter-clockwise, -1 clockwise
        self.rngs: list[np.random.Generator] = []
        self.reset(0)

    def derive(self) -> None:
        """Each robot's constants, from its parameter set."""
        index = self.param_index.tolist()
        own = [params.section(SoloParams) for params in self.params]
        fixed = [constants(params, mona) for params, mona in zip(self.params, self.mona)]
        per = np.array([(o.alpha, o.clean_above, o.stand_max, beta, spin, m.max_wheel_command)
                        for o, (beta, spin, _), m in zip(own, fixed, self.mona)])[index]
        self._alpha, self._above, self._stand_max, self._beta, self._spin = per[:, :5].T
        self._top = per[:, 5:6]
        self._turns = [(own[k].turn_min, own[k].turn_max, fixed[k][2], own[k].leave)
                       for k in index]
        bearings = [tuple(mona.ir_bearings().tolist()) for mona in self.mona]
        self._bearings = [bearings[k] for k in index]

    def reset(self, seed: int) -> None:
        """Start a new episode: every robot following the gradient, generators reseeded."""
        self.state[:] = FOLLOW
        self.until[:] = 0.0
        self.calm[:] = 0.0
        self.direction[:] = 1.0
        self.encounters[:] = 0
        self.rngs = [np.random.default_rng([seed, CONTROLLER_STREAM, int(i)])
                     for i in self.robot_ids]

    def step(self, ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray,
             now: float | np.ndarray) -> Command:
        """Advance every robot's rules (:class:`Longhand`'s, in its order) and answer its
        wheels and cleaner."""
        state, until = self.state, self.until
        times = np.broadcast_to(np.asarray(now, dtype=np.float64), until.shape)
        level = (ground[:, 0].astype(np.float64) + ground[:, 1]) / 2
        seen = ranges < np.inf
        sees = seen.any(axis=1)
        standing = state == STAND
        over = times >= until
        full = standing & over
        for i in np.flatnonzero(full).tolist():  # a full stand: turn in place, then leave
            turn_min, turn_max, rate, leave = self._turns[i]
            rng = self.rngs[i]
            angle = rng.uniform(turn_min, turn_max)
            self.direction[i] = 1.0 if rng.random() < 0.5 else -1.0
            until[i] = times.item(i) + angle / rate
            self.calm[i] = until.item(i) + leave
        state[full] = TURN
        state[standing & ~full & (level < self._above)] = FOLLOW
        state[(state == TURN) & over & ~full] = FOLLOW
        state[(state == AVOID) & ~sees] = FOLLOW
        start = (state <= AVOID) & (level >= self._above) & (times >= self.calm)
        state[start] = STAND
        until[start] = times[start] + self._stand_max[start]
        for i in np.flatnonzero((state == FOLLOW) & sees).tolist():  # turn away from it
            self.direction[i] = turn_away(seen[i].tolist(), self._bearings[i])
            state[i] = AVOID
        wheels = gradient_wheels(ground, self._beta, self._alpha, self._top)
        wheels[state == STAND] = 0.0
        spinning = (state == AVOID) | (state == TURN)
        spin = self.direction[spinning] * self._spin[spinning]
        wheels[spinning, 0] = -spin
        wheels[spinning, 1] = spin
        return Command(wheels=wheels, cleaner=state == STAND)
