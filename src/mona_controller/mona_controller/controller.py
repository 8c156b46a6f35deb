"""The Mona controller: follow the cue gradient, avoid walls, stop and clean on meeting a robot.

Pure and vectorised: one :class:`SwarmController` holds the state of any number of robots, so
the embedded runner steps the whole swarm at once and a controller node holds just its own
robot. Each robot draws from its own random generator, seeded from (episode seed, robot id),
so a robot behaves the same whichever runner hosts it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError, param, validate

#: Behaviour states (also published for markers and recorded in bags).
FOLLOW, AVOID, WAIT, TURN = 0, 1, 2, 3
STATE_NAMES = ('follow', 'avoid', 'wait', 'turn')

#: What a robot does at a wall (docs/model.md).
AVOID_MODES = ('turn-away', 'random-turn')

#: The stream id of controller random generators (placement uses another).
CONTROLLER_STREAM = 1


@dataclasses.dataclass(frozen=True)
class ControllerParams:
    """Parameters of the gradient-following BEECLUST controller (method.md)."""

    speed: float = param(0.08, unit='m/s', low=0.0, high=1.0,
                         doc='forward speed v_r on a clean floor (beta = speed / wheel unit)')
    alpha: float = param(2.0, unit='cue units per wheel unit', low=0.01, high=1e6,
                         doc='gradient gain divisor of eq. 2')
    wait_max: float = param(30.0, unit='s', low=0.0, high=3600.0,
                            doc='w_max of eq. 1, the wait at an infinitely strong cue')
    wait_half_constant: float = param(25000.0, unit='cue^2', low=1.0, high=1e9,
                                      doc='S^2 at which the wait is half of wait_max (eq. 1)')
    turn_min: float = param(math.pi / 2, unit='rad', low=0.0, high=2 * math.pi,
                            doc='smallest turn after a wait (90 deg)')
    turn_max: float = param(math.pi, unit='rad', low=0.0, high=2 * math.pi,
                            doc='largest turn after a wait (180 deg)')
    turn_speed: float = param(0.04, unit='m/s', low=0.001, high=1.0,
                              doc='wheel speed while turning in place (walls, after a wait)')
    avoid: str = param('turn-away', choices=AVOID_MODES,
                       doc="at a wall: 'turn-away' turns in place away from it until no beam "
                           "sees it; 'random-turn' turns by U[turn_min, turn_max] in a random "
                           'direction, blind, as after a wait (classic BEECLUST)')

    def __post_init__(self) -> None:
        validate(self, 'controller.')
        if self.turn_min > self.turn_max:
            raise ParameterError(f'controller.turn_min = {self.turn_min} must not exceed '
                                 f'controller.turn_max = {self.turn_max}')


def waiting_time(cue: np.ndarray | float, params: ControllerParams) -> np.ndarray | float:
    """Eq. 1 (with the S^2 erratum): w = w_max * S^2 / (S^2 + 25000), S in [0, 255]."""
    squared = np.square(cue, dtype=np.float64)
    return params.wait_max * squared / (squared + params.wait_half_constant)


def gradient_wheels(ground: np.ndarray, beta: float | np.ndarray, alpha: float | np.ndarray,
                    max_command: float | np.ndarray) -> np.ndarray:
    """Eq. 2: wheel commands [N, 2] (left, right) from ground readings [N, 2] (left, right).

    The parameters are scalars or per robot (``beta``, ``alpha`` [N], ``max_command`` [N, 1]).

    N_r = (s_l - s_r) / alpha + beta and N_l = (s_r - s_l) / alpha + beta, clamped to
    [0, max_command]: the wheel on the weaker side runs faster, so the robot turns toward the
    stronger cue.
    """
    diff = (ground[:, 0].astype(np.float64) - ground[:, 1]) / alpha
    wheels = np.empty((len(ground), 2))
    np.subtract(beta, diff, out=wheels[:, 0])
    np.add(beta, diff, out=wheels[:, 1])
    return np.minimum(np.maximum(wheels, 0.0, out=wheels), max_command, out=wheels)


@dataclasses.dataclass
class Command:
    """What the controllers answer for one step."""

    wheels: np.ndarray  #: [N, 2] float64, left and right wheel commands (wheel units)
    cleaner: np.ndarray  #: [N] bool, the cleaning actuator


class SwarmController:
    """The controllers of the robots ``robot_ids``; readings and sim time in, commands out.

    Every parameter is also held per robot (arrays of the robots' length), so that
    :meth:`merge` can join the controllers of several episodes, with different parameters,
    into one that steps all their robots at once (the batched engine); each robot computes
    exactly what it computes alone.
    """

    def __init__(self, params: ControllerParams, mona: MonaParams,
                 robot_ids: Sequence[int]) -> None:
        self.params = params
        self.mona = mona
        self.robot_ids = np.asarray(robot_ids, dtype=np.int64)
        self.beta = params.speed / mona.wheel_unit_speed
        if self.beta > mona.max_wheel_command:
            top = mona.max_wheel_command * mona.wheel_unit_speed
            raise ParameterError(f'controller.speed = {params.speed} is out of range: allowed '
                                 f'[0, {top:g}] m/s (beta = speed / wheel unit <= '
                                 f'{mona.max_wheel_command:g})')
        self.turn_command = min(params.turn_speed / mona.wheel_unit_speed,
                                mona.max_wheel_command)
        # In-place turn rate when both wheels run at +-turn_command.
        self.turn_rate = 2 * self.turn_command * mona.wheel_unit_speed / mona.wheel_separation
        self.bearings = mona.ir_bearings()
        n = len(self.robot_ids)
        self.state = np.full(n, FOLLOW, dtype=np.int8)
        self.until = np.zeros(n)  # end time (s) of the current wait or turn
        self.turn_direction = np.ones(n)  # +1 counter-clockwise, -1 clockwise
        self.encounters = np.zeros(n, dtype=np.int64)
        # Per robot: (beta, alpha, max wheel command, wait_max, wait_half_constant, turn_min,
        # turn_max, turn_command, turn_rate), one row per parameter.
        self._per_robot = np.repeat(np.array([[
            self.beta, params.alpha, mona.max_wheel_command, params.wait_max,
            params.wait_half_constant, params.turn_min, params.turn_max, self.turn_command,
            self.turn_rate]]).T, n, axis=1)
        # Robots [start, stop) share IR bearings and the wall behaviour: (start, stop,
        # bearings, random_turn). One span alone; one per episode in a merged controller.
        self._spans = [(0, n, self.bearings, params.avoid == 'random-turn')]
        self.rngs: list[np.random.Generator] = []
        self.reset(0)

    @classmethod
    def merge(cls, controllers: Sequence[SwarmController]) -> SwarmController:
        """One controller stepping the robots of all ``controllers``, in order.

        The parts take over: their generators are shared, and their state arrays become
        views of the merged ones, so each part still shows its robots' state, and a part can
        be merged again (into another batch) once this one is no longer stepped. Its
        :meth:`step` takes ``now`` per robot (each part's own time).
        """
        merged = cls.__new__(cls)
        merged.params = None  # per robot: no single set of parameters
        merged.mona = None
        merged.robot_ids = np.concatenate([c.robot_ids for c in controllers])
        merged.rngs = [rng for c in controllers for rng in c.rngs]
        merged._per_robot = np.concatenate([c._per_robot for c in controllers], axis=1)
        merged._spans, start = [], 0
        for part in controllers:
            for first, stop, bearings, random_turn in part._spans:
                merged._spans.append((start + first, start + stop, bearings, random_turn))
            start += len(part.robot_ids)
        for name in ('state', 'until', 'turn_direction', 'encounters'):
            joined = np.concatenate([getattr(c, name) for c in controllers])
            setattr(merged, name, joined)
            start = 0
            for part in controllers:  # the parts see (and keep) their slice of the whole
                stop = start + len(part.robot_ids)
                setattr(part, name, joined[start:stop])
                start = stop
        return merged

    def reset(self, seed: int) -> None:
        """Start a new episode: every robot following the gradient, generators reseeded."""
        self.state[:] = FOLLOW
        self.until[:] = 0.0
        self.turn_direction[:] = 1.0
        self.encounters[:] = 0
        self.rngs = [np.random.default_rng([seed, CONTROLLER_STREAM, int(i)])
                     for i in self.robot_ids]

    def _start_turn(self, i: int, now: float) -> None:
        """Robot ``i`` turns in place by U[turn_min, turn_max] in a random direction, blind."""
        rng, per_robot = self.rngs[i], self._per_robot
        angle = rng.uniform(per_robot[_TURN_MIN, i], per_robot[_TURN_MAX, i])
        self.turn_direction[i] = 1.0 if rng.random() < 0.5 else -1.0
        self.state[i] = TURN
        self.until[i] = now + angle / per_robot[_TURN_RATE, i]

    def step(self, ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray,
             now: float | np.ndarray) -> Command:
        """Advance every robot's behaviour and answer its wheel and cleaner commands.

        Args:
            ground: [N, 2] uint8 ground readings (left, right), 0..255.
            ranges: [N, K] IR ranges from the body edge (m); inf where nothing is seen.
            is_robot: [N, K] True where the obstacle seen is a robot.
            now: sim time of the readings (s); or [N], each robot's (a merged controller).
        """
        state, until, per_robot = self.state, self.until, self._per_robot
        each = np.ndim(now) > 0
        seen = ranges < np.inf
        robot_beams = seen & is_robot
        robot_seen = robot_beams.any(axis=1)
        wall_beams = seen ^ robot_beams
        wall_seen = wall_beams.any(axis=1)

        timed_out = (state >= WAIT) & (now >= until)
        if timed_out.any():
            for i in np.flatnonzero(timed_out):
                if state[i] == TURN:
                    state[i] = FOLLOW
                    continue
                self._start_turn(i, now[i] if each else now)
        state[(state == AVOID) & ~wall_seen] = FOLLOW

        if robot_seen.any():
            meet = np.flatnonzero(robot_seen & (state <= AVOID))
            if len(meet):
                cue = ground[meet].astype(np.float64).mean(axis=1)
                state[meet] = WAIT
                # Eq. 1 (waiting_time) with each robot's parameters.
                squared = np.square(cue, dtype=np.float64)
                wait = (per_robot[_WAIT_MAX, meet] * squared
                        / (squared + per_robot[_WAIT_HALF, meet]))
                until[meet] = (now[meet] if each else now) + wait
                self.encounters[meet] += 1

        if wall_seen.any():
            start_avoid = np.flatnonzero(wall_seen & (state == FOLLOW))
            if len(start_avoid):
                self._start_avoiding(start_avoid, wall_beams, now, each)

        wheels = gradient_wheels(ground, per_robot[_BETA], per_robot[_ALPHA],
                                 per_robot[_MAX_COMMAND, :, None])
        cleaner = state == WAIT
        if state.any():  # anyone not following the gradient
            turning = (state == TURN) | (state == AVOID)
            spin = self.turn_direction[turning] * per_robot[_TURN_COMMAND, turning]
            wheels[turning, 0] = -spin
            wheels[turning, 1] = spin
            wheels[cleaner] = 0.0
        return Command(wheels=wheels, cleaner=cleaner)

    def _start_avoiding(self, start_avoid: np.ndarray, wall_beams: np.ndarray,
                        now: float | np.ndarray, each: bool) -> None:
        """The robots ``start_avoid`` (following, a wall seen) start avoiding it."""
        for first, stop, bearings, random_turn in self._spans:
            if len(self._spans) > 1:  # only this span's robots (one span: all of them)
                robots = start_avoid[(start_avoid >= first) & (start_avoid < stop)]
                if not len(robots):
                    continue
            else:
                robots = start_avoid
            if random_turn:
                for i in robots:
                    self._start_turn(i, now[i] if each else now)
            else:
                # Turn away from the side the wall is on (bearings > 0 are on the left). The
                # product is taken over one span's rows, as the episode alone takes it.
                side = wall_beams[robots] @ bearings
                self.turn_direction[robots] = np.where(side > 0, -1.0, 1.0)
                self.state[robots] = AVOID


# Rows of SwarmController._per_robot.
(_BETA, _ALPHA, _MAX_COMMAND, _WAIT_MAX, _WAIT_HALF, _TURN_MIN, _TURN_MAX, _TURN_COMMAND,
 _TURN_RATE) = range(9)
