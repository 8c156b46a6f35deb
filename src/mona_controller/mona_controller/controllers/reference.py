"""The BEECLUST rules robot by robot in plain Python, and the check that a controller obeys them.

:class:`Longhand` is one Mona's BEECLUST controller written out rule after rule in plain
Python floats (the paper's eq. 1 and eq. 2 and its state machine; docs/model.md,
Controller): slow, and meant to be plainly right. :func:`check_controller` steps a fast
controller (lone or merged) and one Longhand per robot with the same random readings
(:func:`random_readings`) and times, and demands the same bits every step: wheels, cleaner,
state, the end of a wait or turn, turn direction, encounters and each generator's state.
It ships beside the fast code so that any implementation of these rules, or any change to
:class:`~mona_controller.controllers.beeclust.SwarmController`, is checked by one call
(tests/unit/test_controller_speed_exact.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from mona_controller.controllers.base import Command, Controller
from mona_controller.controllers.beeclust import (
    AVOID,
    CONTROLLER_STREAM,
    FOLLOW,
    TURN,
    WAIT,
    BeeclustParams,
)
from mona_controller.controllers.params import ControllerParams
from mona_controller.mona import MonaParams


class Longhand:
    """One robot's BEECLUST controller, rule after rule, in plain Python.

    Attributes:
        state: ``FOLLOW``, ``AVOID``, ``WAIT`` or ``TURN``.
        until: the end (s) of the current wait or turn.
        direction: +1 counter-clockwise, -1 clockwise (turning, or avoiding a wall).
        encounters: the robots met so far.
        rng: the robot's generator, ``default_rng([seed, CONTROLLER_STREAM, robot_id])``.
    """

    def __init__(self, params: ControllerParams, mona: MonaParams, robot_id: int,
                 seed: int) -> None:
        self.params, self.mona = params.section(BeeclustParams), mona
        self.beta = params.speed / mona.wheel_unit_speed
        # An in-place turn's wheel command: turn_speed, the robot's own speed, or full.
        turning = {'turn_speed': self.params.turn_speed, 'speed': params.speed,
                   'full': math.inf}[self.params.turn_at]
        self.turn_command = min(turning / mona.wheel_unit_speed, mona.max_wheel_command)
        # Both wheels at +-turn_command turn the robot in place at this rate (rad/s).
        self.turn_rate = 2 * self.turn_command * mona.wheel_unit_speed / mona.wheel_separation
        self.bearings = mona.ir_bearings().tolist()
        self.state, self.until, self.direction, self.encounters = FOLLOW, 0.0, 1.0, 0
        self.rng = np.random.default_rng([seed, CONTROLLER_STREAM, robot_id])

    def wait(self, left: int, right: int) -> float:
        """Eq. 1 with the S^2 erratum: w = w_max * S^2 / (S^2 + c), S = (s_l + s_r) / 2."""
        cue = (left + right) / 2
        squared = cue * cue
        return self.params.wait_max * squared / (squared + self.params.wait_half_constant)

    def follow(self, left: int, right: int) -> tuple[float, float]:
        """Eq. 2: N_l = (s_r - s_l) / alpha + beta, N_r = (s_l - s_r) / alpha + beta, each
        clamped to [0, max_wheel_command]."""
        top = self.mona.max_wheel_command
        wheel_left = (right - left) / self.params.alpha + self.beta
        wheel_right = (left - right) / self.params.alpha + self.beta
        return min(max(wheel_left, 0.0), top), min(max(wheel_right, 0.0), top)

    def turn(self, now: float) -> None:
        """Turn in place, blind, by theta ~ U[turn_min, turn_max], counter-clockwise or
        clockwise with probability 1/2 (after a wait; at a wall with ``random-turn``)."""
        angle = self.rng.uniform(self.params.turn_min, self.params.turn_max)
        self.direction = 1.0 if self.rng.random() < 0.5 else -1.0
        self.state, self.until = TURN, now + angle / self.turn_rate

    def step(self, ground: Sequence[int], ranges: Sequence[float], is_robot: Sequence[bool],
             now: float) -> tuple[tuple[float, float], bool]:
        """One step of the rules, in the order they apply.

        Args:
            ground: (s_l, s_r), 0..255.
            ranges: the K IR ranges (m), inf where nothing is seen.
            is_robot: per beam, whether what it sees is a robot.
            now: sim time (s).

        Returns:
            The (left, right) wheel commands and the cleaner.
        """
        left, right = (int(value) for value in ground)
        seen = [distance < math.inf for distance in ranges]
        robot = any(sees and flag for sees, flag in zip(seen, is_robot))
        walls = [sees and not flag for sees, flag in zip(seen, is_robot)]
        wall = any(walls)
        if self.state in (WAIT, TURN) and now >= self.until:
            if self.state == TURN:
                self.state = FOLLOW
            else:  # a wait ends in a random turn
                self.turn(now)
        if self.state == AVOID and not wall:
            self.state = FOLLOW
        if robot and self.state in (FOLLOW, AVOID):  # meet a robot: stop, clean, wait
            self.until = now + self.wait(left, right)
            self.state, self.encounters = WAIT, self.encounters + 1
        if wall and self.state == FOLLOW:
            if self.params.avoid == 'random-turn':
                self.turn(now)
            else:  # away from the sign of the bearings seeing the wall, summed from the right
                side = 0.0
                for sees, bearing in zip(walls, self.bearings):
                    if sees:
                        side += bearing
                self.direction = -1.0 if side > 0 else 1.0
                self.state = AVOID
        if self.state == FOLLOW:
            wheels = self.follow(left, right)
        elif self.state == WAIT:
            wheels = (0.0, 0.0)
        else:  # turning or avoiding: in place
            spin = self.direction * self.turn_command
            wheels = (-spin, spin)
        return wheels, self.state == WAIT


def random_readings(rng: np.random.Generator, n: int,
                    k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random readings of ``n`` robots with ``k`` beams, rich in the cases that matter.

    Ground bytes, often equal or extreme (0, 255); beams that see nothing, a robot or a
    wall, robot flags on beams that see nothing (to be ignored); walls alone, often in mirror
    image patterns whose bearings sum to about zero (the side then hangs on the order of the
    sum); and often nothing at all.

    Returns:
        ground [n, 2] uint8, ranges [n, k] float32, is_robot [n, k] bool.
    """
    ground = rng.integers(0, 256, (n, 2)).astype(np.uint8)
    same = rng.random(n) < 0.2
    ground[same, 1] = ground[same, 0]
    extreme = rng.random((n, 2)) < 0.1
    ground[extreme] = rng.choice(np.array([0, 255], dtype=np.uint8), extreme.sum())
    ranges = np.where(rng.random((n, k)) < 0.15, rng.random((n, k)) * 0.03,
                      np.inf).astype(np.float32)
    is_robot = rng.random((n, k)) < 0.3
    for i in np.flatnonzero(rng.random(n) < 0.15):  # a wall, nothing else
        beams = rng.random(k) < 0.5
        if rng.random() < 0.6:
            beams[k - k // 2:] = beams[:k // 2][::-1]  # a mirror image
        ranges[i] = np.where(beams, 0.01, np.inf)
        is_robot[i, beams] = False
    ranges[rng.random(n) < 0.4] = np.inf
    return ground, ranges, is_robot


#: What :func:`check_controller` compares, robot by robot, in this order: the name, the
#: controller's attribute, the reference's, and the dtype the controller must hold it in.
FIELDS = (('state', 'state', 'state', np.int8), ('until', 'until', 'until', np.float64),
          ('turn direction', 'turn_direction', 'direction', np.float64),
          ('encounters', 'encounters', 'encounters', np.int64))


def check_controller(controller: Controller | Callable[[], Controller], *, seed: int = 0,
                     steps: int = 400, period: float = 0.25,
                     starts: Sequence[float] | np.ndarray | None = None,
                     readings_seed: int | Sequence[int] | None = None) -> np.ndarray:
    """Step a BEECLUST controller and a :class:`Longhand` per robot alike; demand the same bits.

    Each robot's reference runs its own parameter set (``params[param_index[i]]`` on
    ``mona[param_index[i]]``) with its own id, so a merged controller is checked robot by
    robot as alone. Every step both get the same :func:`random_readings` and time, and the
    wheels, cleaner, ``state``, ``until``, ``turn_direction``, ``encounters`` and each
    generator's state must be equal to the bit.

    Args:
        controller: the controller (it is reset with ``seed``), or a callable that builds
            one. It needs BEECLUST's per-robot state: ``until``, ``turn_direction``,
            ``rngs``.
        seed: the episode seed (each robot's generator).
        steps: the steps to compare.
        period: sim seconds per step.
        starts: each robot's time at step 0 (s), e.g. one per part of a merged controller:
            ``now`` is then an [N] array, ``starts + step * period``. None: one float,
            ``step * period``, for all robots.
        readings_seed: seeds the readings (default: ``seed``).

    Returns:
        The robots' states after each step, [steps, N] int8 (which behaviours the check
        went through).

    Raises:
        AssertionError: naming the first step, robot and field where the controller and
            the reference differ.
    """
    fast = controller if isinstance(controller, Controller) else controller()
    fast.reset(seed)
    ids = fast.robot_ids.tolist()
    n = len(ids)
    hands = [Longhand(fast.params[k], fast.mona[k], robot, seed)
             for k, robot in zip(fast.param_index.tolist(), ids)]
    if starts is not None:
        starts = np.asarray(starts, dtype=np.float64)
        if starts.shape != (n,):
            raise ValueError(f'starts has shape {starts.shape}, expected ({n},)')
    rng = np.random.default_rng(seed if readings_seed is None else readings_seed)
    trace = np.empty((steps, n), dtype=np.int8)
    for step in range(steps):
        ground, ranges, is_robot = random_readings(rng, n, fast.mona[0].ir_count)
        now: float | np.ndarray
        if starts is None:
            now = step * period
            times = [now] * n
        else:
            now = starts + step * period
            times = now.tolist()
        command = fast.step(ground, ranges, is_robot, now)
        answers = [hand.step(ground[i].tolist(), ranges[i].tolist(), is_robot[i].tolist(),
                             times[i]) for i, hand in enumerate(hands)]
        expected = {'wheels': np.array([wheels for wheels, _ in answers], dtype=np.float64),
                    'cleaner': np.array([cleaner for _, cleaner in answers], dtype=bool)}
        got = _command_fields(command, n, step)
        for name, mine, theirs, dtype in FIELDS:
            got[name] = _held(getattr(fast, mine), name, dtype, n, step)
            expected[name] = np.array([getattr(hand, theirs) for hand in hands], dtype=dtype)
        _compare(got, expected, fast.rngs, hands, ids, step)  # type: ignore[attr-defined]
        trace[step] = fast.state
    return trace


def _command_fields(command: Command, n: int, step: int) -> dict[str, np.ndarray]:
    """The command's wheels and cleaner, once their shape and dtype are right."""
    return {'wheels': _held(command.wheels, 'wheels', np.float64, n, step, (n, 2)),
            'cleaner': _held(command.cleaner, 'cleaner', np.bool_, n, step)}


def _held(value: np.ndarray, name: str, dtype: type, n: int, step: int,
          shape: tuple[int, ...] | None = None) -> np.ndarray:
    shape = (n,) if shape is None else shape
    if not isinstance(value, np.ndarray) or value.shape != shape or value.dtype != dtype:
        found = (value.shape, value.dtype) if isinstance(value, np.ndarray) else type(value)
        raise AssertionError(f'step {step}: {name} is {found}, expected an array of shape '
                             f'{shape} and dtype {np.dtype(dtype)}')
    return value


def _compare(got: dict[str, np.ndarray], expected: dict[str, np.ndarray],
             rngs: Sequence[np.random.Generator], hands: Sequence[Longhand],
             ids: Sequence[int], step: int) -> None:
    """Raise at the first robot (then field, in order) where ``got`` is not ``expected``."""
    n = len(hands)
    # Byte comparison: a -0.0 for a 0.0, or any last bit, is a difference.
    bad = {name: (np.ascontiguousarray(value).view(np.uint8).reshape(n, -1)
                  != np.ascontiguousarray(expected[name]).view(np.uint8).reshape(n, -1)
                  ).any(axis=1) for name, value in got.items()}
    bad['generator'] = np.array([rng.bit_generator.state != hand.rng.bit_generator.state
                                 for rng, hand in zip(rngs, hands)], dtype=bool)
    wrong = np.logical_or.reduce(list(bad.values()))
    if not wrong.any():
        return
    i = int(np.flatnonzero(wrong)[0])
    name = next(name for name, rows in bad.items() if rows[i])
    if name == 'generator':
        mine, theirs = rngs[i].bit_generator.state, hands[i].rng.bit_generator.state
    else:
        mine, theirs = got[name][i].tolist(), expected[name][i].tolist()
    raise AssertionError(f'step {step}, robot {ids[i]} (row {i}): {name} is {mine!r}, the '
                         f'reference has {theirs!r}')
