"""The BEECLUST controller: follow the cue gradient, avoid walls, stop and clean on meeting a
robot (the paper's eq. 1 and eq. 2; docs/model.md, Controller).

Pure and vectorised: one :class:`SwarmController` holds the state of any number of robots, so
the embedded runner steps the whole swarm at once and a controller node holds just its own
robot. Each robot draws from its own random generator, seeded from (episode seed, robot id),
so a robot behaves the same whichever runner hosts it. It is the ``beeclust`` kind of
:mod:`mona_controller.controllers` (the seam every controller implements): its parameters
are the section ``controller.beeclust.*`` (:class:`BeeclustParams`), its states
:data:`STATES`; :mod:`mona_controller.controllers.reference` writes its rules out robot by
robot.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence

import numpy as np

from mona_controller.controllers.base import Command, Controller, State
from mona_controller.controllers.params import ControllerParams
from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError, param, validate

#: Behaviour states (also published for markers and recorded in bags).
FOLLOW, AVOID, WAIT, TURN = 0, 1, 2, 3
#: The states as observers show them, by code: robots following the gradient green, avoiding
#: a wall orange, waiting (and cleaning) red, turning blue.
STATES = (State('follow', (0.20, 0.75, 0.25, 1.0)), State('avoid', (1.00, 0.60, 0.00, 1.0)),
          State('wait', (0.90, 0.10, 0.10, 1.0)), State('turn', (0.25, 0.45, 1.00, 1.0)))

#: What a robot does at a wall (docs/model.md).
AVOID_MODES = ('turn-away', 'random-turn')
#: How fast a robot turns in place (after a wait, at a wall): at turn_speed, at its own
#: speed, or with its wheels at their top command.
TURN_SPEEDS = ('turn_speed', 'speed', 'full')

#: The stream id of controller random generators (placement uses another).
CONTROLLER_STREAM = 1


@dataclasses.dataclass(frozen=True)
class BeeclustParams:
    """The gradient-following BEECLUST controller's parameters, controller.beeclust.* (the
    paper's eq. 1 and eq. 2 and its parameter table; docs/model.md, Controller)."""

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
    turn_at: str = param('turn_speed', choices=TURN_SPEEDS,
                         doc="the wheels' speed in an in-place turn: 'turn_speed'; 'speed' the "
                             "robot's own (controller.speed); 'full' the top wheel command "
                             "(as the first author's Webots controller turned)")
    avoid: str = param('turn-away', choices=AVOID_MODES,
                       doc="at a wall: 'turn-away' turns in place away from it until no beam "
                           "sees it; 'random-turn' turns by U[turn_min, turn_max] in a random "
                           'direction, blind, as after a wait (classic BEECLUST)')

    def __post_init__(self) -> None:
        validate(self, 'controller.beeclust.')
        if self.turn_min > self.turn_max:
            raise ParameterError(f'controller.beeclust.turn_min = {self.turn_min} must not '
                                 f'exceed controller.beeclust.turn_max = {self.turn_max}')

    def check(self, controller: ControllerParams) -> None:
        """Refuse what the whole ``controller`` section makes impossible.

        Raises:
            ParameterError: ``turn_at = 'speed'`` with ``controller.speed`` 0.
        """
        if self.turn_at == 'speed' and controller.speed == 0:
            raise ParameterError("controller.beeclust.turn_at = 'speed' needs controller.speed "
                                 '> 0 (a robot of speed 0 would never finish a turn)')


def waiting_time(cue: np.ndarray | float, params: BeeclustParams) -> np.ndarray | float:
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


def wheel_constants(params: ControllerParams, mona: MonaParams) -> tuple[float, float, float]:
    """beta (eq. 2's forward command on a clean floor), the wheel command of an in-place turn
    (``turn_at``: turn_speed or the robot's speed, within the wheels' top command, or the top
    command) and the turn rate it gives (rad/s)."""
    beta = params.speed / mona.wheel_unit_speed
    own = params.section(BeeclustParams)
    if own.turn_at == 'full':
        turn_command = mona.max_wheel_command
    else:
        speed = own.turn_speed if own.turn_at == 'turn_speed' else params.speed
        turn_command = min(speed / mona.wheel_unit_speed, mona.max_wheel_command)
    return beta, turn_command, 2 * turn_command * mona.wheel_unit_speed / mona.wheel_separation


class SwarmController(Controller):
    """The BEECLUST controllers of the robots ``robot_ids`` (the ``beeclust`` kind).

    Every parameter is also held per robot, so that :meth:`merge` can join the controllers
    of several episodes, with different parameters, into one that steps all their robots at
    once (the batched engine); each robot computes exactly what it computes alone.

    A step costs a fixed number of array operations over all robots (the Python cost of a
    numpy call, not the robots, dominates it) and a little plain Python per robot whose state
    changes (a few in a step of hundreds): what a robot does follows from four bits of a code
    (:data:`_ACTIONS`). Eq. 1 and the wheel commands are looked up: ground readings are
    bytes, so eq. 1 depends on them only through s_l + s_r (511 values), and a robot's wheels
    only through s_l - s_r and whether it follows the gradient, waits, or turns which way
    (4 x 511 pairs). The tables are worked out once per parameter set by the formulas
    themselves (:func:`waiting_time`, :func:`gradient_wheels`), so a lookup is bit for bit
    the formula. ``state`` and ``turn_direction`` are the controller's to change: each
    robot's block of the command table is kept with them.

    ``state`` holds :data:`FOLLOW`, :data:`AVOID`, :data:`WAIT` or :data:`TURN`.
    """

    STATES = STATES
    Params = BeeclustParams

    #: Per-robot state (the rest follows from the parameters: :meth:`derive`).
    PER_ROBOT = (*Controller.PER_ROBOT, 'until', 'turn_direction', '_command_block', 'rngs')

    def __init__(self, params: ControllerParams, mona: MonaParams,
                 robot_ids: Sequence[int]) -> None:
        """The robots ``robot_ids``, reset with seed 0.

        Raises:
            ParameterError: the speed needs a wheel command beyond ``mona.max_wheel_command``.
        """
        beta, _, _ = wheel_constants(params, mona)
        if beta > mona.max_wheel_command:
            top = mona.max_wheel_command * mona.wheel_unit_speed
            raise ParameterError(f'controller.speed = {params.speed} is out of range: allowed '
                                 f'[0, {top:g}] m/s (beta = speed / wheel unit <= '
                                 f'{mona.max_wheel_command:g})')
        super().__init__(params, mona, robot_ids)
        n = len(self.robot_ids)
        self.until = np.zeros(n)  # end time (s) of the current wait or turn
        self.turn_direction = np.ones(n)  # +1 counter-clockwise, -1 clockwise
        # Each robot's block of its command table (_FOLLOWING, ...), kept with its state and
        # turn direction: a step reads it instead of working it out from them.
        self._command_block = np.zeros(n, dtype=np.intp)
        self.rngs: list[np.random.Generator] = []
        self.reset(0)

    def derive(self) -> None:
        """Each robot's constants, as lists read one robot at a time (turn_min, turn_max and
        turn rate; IR bearings; whether it turns blind at a wall), and the lookup tables of
        the parameter sets with each robot's first rows in them."""
        index = self.param_index.tolist()
        sets = list(zip(self.params, self.mona))
        constants = [wheel_constants(params, mona) for params, mona in sets]
        own = [params.section(BeeclustParams) for params in self.params]
        turns = [(mine.turn_min, mine.turn_max, turn_rate)
                 for mine, (_, _, turn_rate) in zip(own, constants)]
        bearings = [tuple(mona.ir_bearings().tolist()) for mona in self.mona]
        self._turn = [turns[k] for k in index]
        self._bearings = [bearings[k] for k in index]
        self._random_turn = [own[k].avoid == 'random-turn' for k in index]
        self._beams = np.ones(self.mona[0].ir_count, dtype=bool)
        # Sets whose Monas differ only where the tables do not look (e.g. the IR range)
        # share one table: a batch gathers from fewer, smaller arrays.
        keys = [(mine, mona.max_wheel_command, beta, turn_command)
                for mine, (_, mona), (beta, turn_command, _) in zip(own, sets, constants)]
        unique = list(dict.fromkeys(keys))
        tables = [_tables(*key) for key in unique]
        self._waits = np.concatenate([waits for waits, _ in tables])
        self._commands = np.concatenate([commands for _, commands in tables])
        table = np.array([unique.index(key) for key in keys], dtype=np.intp)[self.param_index]
        self._wait_row = (table * _VALUES).tolist()
        self._command_row = table * _COMMANDS + _ZERO_DIFFERENCE

    def reset(self, seed: int) -> None:
        """Start a new episode: every robot following the gradient, generators reseeded."""
        self.state[:] = FOLLOW
        self.until[:] = 0.0
        self.turn_direction[:] = 1.0
        self.encounters[:] = 0
        self._command_block[:] = _FOLLOWING
        self.rngs = [np.random.default_rng([seed, CONTROLLER_STREAM, int(i)])
                     for i in self.robot_ids]

    def step(self, ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray,
             now: float | np.ndarray) -> Command:
        """Advance every robot's behaviour and answer its wheel and cleaner commands.

        Args:
            ground: [N, 2] uint8 ground readings (left, right), 0..255.
            ranges: [N, K] IR ranges from the body edge (m); inf where nothing is seen.
            is_robot: [N, K] True where the obstacle seen is a robot.
            now: sim time of the readings (s); or [N], each robot's (a merged controller).

        Returns:
            Each robot's wheels (eq. 2, stopped, or turning in place) and cleaner (on while
            it waits).
        """
        seen = ranges < np.inf
        robot_beams = seen & is_robot
        wall_beams = seen ^ robot_beams
        # Each robot's code: state << 3 | its wait or turn is over << 2 | a beam sees a robot
        # << 1 | a beam sees a wall (products by powers of two: quicker than shifts of int8).
        # Whether any beam sees one is a boolean product with a vector of ones, several
        # times faster than .any(axis=1) over a few beams.
        code = self.state * 8
        code |= (now >= self.until).view(np.int8) * 4
        code |= (robot_beams @ self._beams).view(np.int8) * 2
        code |= (wall_beams @ self._beams).view(np.int8)
        actions = _ACTIONS.take(code)
        acting = actions.nonzero()[0]
        if len(acting):
            self._act(acting.tolist(), actions, ground, wall_beams, now)
        # Every robot's wheels by its command block and s_l - s_r (see _tables).
        rows = self._command_row + self._command_block
        rows += ground[:, 0]
        rows -= ground[:, 1]
        wheels = self._commands.take(rows).view(np.float64).reshape(-1, 2)
        return Command(wheels=wheels, cleaner=self.state == WAIT)

    def _act(self, robots: list[int], actions: np.ndarray, ground: np.ndarray,
             wall_beams: np.ndarray, now: float | np.ndarray) -> None:
        """The ``robots`` carry out their ``actions`` (:data:`_ACTIONS`, of every robot) at
        ``now`` (one time, or each robot's); one by one, as they are few."""
        state, until, block = self.state, self.until, self._command_block
        each = now if isinstance(now, np.ndarray) and now.ndim > 0 else None
        for i in robots:
            action, now_i = actions.item(i), now if each is None else each.item(i)
            if action == _FOLLOW:
                state[i] = FOLLOW
                block[i] = _FOLLOWING
            elif action == _MEET:  # wait for eq. 1 of the mean cue, by s_l + s_r
                total = ground.item(i, 0) + ground.item(i, 1)
                until[i] = now_i + self._waits[self._wait_row[i] + total]
                state[i] = WAIT
                block[i] = _WAITING
                self.encounters[i] += 1
            elif action == _TURN or self._random_turn[i]:
                # A wait is over, or a wall (classic BEECLUST): turn in place by
                # U[turn_min, turn_max] in a random direction, blind.
                rng = self.rngs[i]
                turn_min, turn_max, turn_rate = self._turn[i]
                angle = rng.uniform(turn_min, turn_max)
                if rng.random() < 0.5:
                    self.turn_direction[i], block[i] = 1.0, _COUNTER_CLOCKWISE
                else:
                    self.turn_direction[i], block[i] = -1.0, _CLOCKWISE
                state[i] = TURN
                until[i] = now_i + angle / turn_rate
            else:
                self._turn_away(i, wall_beams[i])

    def _turn_away(self, i: int, wall_beams: np.ndarray) -> None:
        """Robot ``i`` (following) turns in place away from the side of the wall its
        ``wall_beams`` see: the sign of the sum of their bearings (> 0 on the left), added
        beam after beam from the right, so that a sum of about zero has the same sign in any
        batch."""
        side = 0.0
        for sees, bearing in zip(wall_beams.tolist(), self._bearings[i]):
            if sees:
                side += bearing
        if side > 0:
            self.turn_direction[i], self._command_block[i] = -1.0, _CLOCKWISE
        else:
            self.turn_direction[i], self._command_block[i] = 1.0, _COUNTER_CLOCKWISE
        self.state[i] = AVOID


#: What a robot does in a step (SwarmController._act).
_NOTHING, _FOLLOW, _MEET, _TURN, _AVOID = range(5)


def _action(state: int, over: bool, robot: bool, wall: bool) -> int:
    """The step of a robot in ``state``, when its wait or turn is ``over`` or not and a beam
    sees a ``robot``, a ``wall`` or not: the BEECLUST rules in the order they apply."""
    if state == WAIT:
        return _TURN if over else _NOTHING  # a wait ends in a random turn
    if state == TURN and not over:
        return _NOTHING
    # Following, avoiding, or following again from this very step (the turn is over).
    if robot:
        return _MEET  # a robot: stop and wait
    if state == AVOID:
        return _NOTHING if wall else _FOLLOW  # avoid until no beam sees the wall
    if wall:
        return _AVOID
    return _FOLLOW if state == TURN else _NOTHING


#: The action of every code state << 3 | over << 2 | robot << 1 | wall.
_ACTIONS = np.array([_action(code >> 3, bool(code & 4), bool(code & 2), bool(code & 1))
                     for code in range(32)], dtype=np.int8)

#: Ground readings are 0..255: s_l + s_r and s_l - s_r + 255 take 511 values.
_VALUES = 511
_ZERO_DIFFERENCE = 255
#: A command table: 4 blocks of one row per s_l - s_r, for a robot following the gradient
#: (eq. 2), waiting (stopped), turning in place (turning or avoiding) counter-clockwise,
#: clockwise. The first row of each block:
_FOLLOWING, _WAITING, _COUNTER_CLOCKWISE, _CLOCKWISE = (block * _VALUES for block in range(4))
_COMMANDS = 4 * _VALUES


@functools.lru_cache(maxsize=64)
def _tables(params: BeeclustParams, max_command: float, beta: float,
            turn_command: float) -> tuple[np.ndarray, np.ndarray]:
    """The lookup tables of one parameter set (read-only, shared by controllers).

    Waits [511]: eq. 1 at s_l + s_r (of the readings' mean). Commands [4 * 511] complex (one
    gather of 16-byte rows is several times quicker than of rows of a 2-D array), the real
    and imaginary parts of a row the (left, right) wheels, at row block + s_l - s_r + 255:
    eq. 2 (following), (0, 0) (waiting), (-spin, spin) with spin = direction * turn_command
    (turning in place or away from a wall, direction +1, -1). Each is its formula on readings
    with that sum or difference, all that it depends on.
    """
    total = np.arange(_VALUES)
    left = np.minimum(total, 255)
    ground = np.stack([left, total - left], axis=1).astype(np.uint8)
    waits = np.asarray(waiting_time(ground.astype(np.float64).mean(axis=1), params))
    difference = total - _ZERO_DIFFERENCE
    ground = np.stack([np.maximum(difference, 0), np.maximum(-difference, 0)],
                      axis=1).astype(np.uint8)
    commands = np.zeros((_COMMANDS, 2))  # (left, right); waiting: (0, 0)
    commands[_FOLLOWING:_WAITING] = gradient_wheels(ground, beta, params.alpha, max_command)
    for first, direction in ((_COUNTER_CLOCKWISE, 1.0), (_CLOCKWISE, -1.0)):
        spin = direction * turn_command
        commands[first:first + _VALUES] = (-spin, spin)
    packed = commands.view(np.complex128).ravel()
    waits.flags.writeable = packed.flags.writeable = False
    return waits, packed
