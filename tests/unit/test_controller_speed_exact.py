"""The vectorised controller, lone and merged, against its rules written out robot by robot.

SwarmController.step computes its robots' behaviour with lookup tables, one code per robot
and Python for the few robots whose state changes; a merged controller steps the robots of
several episodes, with different parameters, at once. Each robot must compute bit for bit
what the rules below compute for it alone: wheels, cleaner, state, until, turn direction,
encounters, and the same draws from its own generator.
"""

import dataclasses
import math

import numpy as np
import pytest

from mona_controller.controller import (AVOID, CONTROLLER_STREAM, FOLLOW, TURN, WAIT,
                                        ControllerParams, SwarmController, gradient_wheels,
                                        waiting_time)
from mona_controller.mona import MonaParams

K = MonaParams().ir_count


class Longhand:
    """One robot's controller, rule after rule, in plain Python."""

    def __init__(self, params, mona, robot_id, seed):
        self.params, self.mona = params, mona
        self.beta = params.speed / mona.wheel_unit_speed
        self.turn_command = min(params.turn_speed / mona.wheel_unit_speed,
                                mona.max_wheel_command)
        self.turn_rate = 2 * self.turn_command * mona.wheel_unit_speed / mona.wheel_separation
        self.bearings = mona.ir_bearings().tolist()
        self.state, self.until, self.direction, self.encounters = FOLLOW, 0.0, 1.0, 0
        self.rng = np.random.default_rng([seed, CONTROLLER_STREAM, robot_id])

    def turn(self, now):
        angle = self.rng.uniform(self.params.turn_min, self.params.turn_max)
        self.direction = 1.0 if self.rng.random() < 0.5 else -1.0
        self.state, self.until = TURN, now + angle / self.turn_rate

    def step(self, ground, ranges, is_robot, now):
        seen = ranges < np.inf
        walls = (seen & ~is_robot).tolist()
        robot, wall = bool((seen & is_robot).any()), any(walls)
        if self.state in (WAIT, TURN) and now >= self.until:
            if self.state == TURN:
                self.state = FOLLOW
            else:
                self.turn(now)
        if self.state == AVOID and not wall:
            self.state = FOLLOW
        if robot and self.state in (FOLLOW, AVOID):
            cue = ground.astype(np.float64).mean()
            self.until = now + waiting_time(cue, self.params)
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
            wheels = gradient_wheels(ground[None], self.beta, self.params.alpha,
                                     self.mona.max_wheel_command)[0].tolist()
        elif self.state == WAIT:
            wheels = [0.0, 0.0]
        else:
            spin = self.direction * self.turn_command
            wheels = [-spin, spin]
        return wheels, self.state == WAIT


#: Wall beams (right to left) whose bearings sum to exactly zero, on one side, on both.
WALLS = [(0, 4), (1, 3), (0, 1, 3, 4), (2,), (0, 2, 4), (0,), (4,), (0, 1), (3, 4), (1, 2, 3)]


def readings(rng, n):
    """Random readings of ``n`` robots: ground bytes (often equal, often extreme), beams that
    see nothing, a robot or a wall (also as symmetric patterns), robot flags on empty beams."""
    ground = rng.integers(0, 256, (n, 2)).astype(np.uint8)
    same = rng.random(n) < 0.2
    ground[same, 1] = ground[same, 0]
    extreme = rng.random((n, 2)) < 0.1
    ground[extreme] = rng.choice(np.array([0, 255], dtype=np.uint8), extreme.sum())
    ranges = np.where(rng.random((n, K)) < 0.15, rng.random((n, K)) * 0.03,
                      np.inf).astype(np.float32)
    is_robot = rng.random((n, K)) < 0.3
    for i in np.flatnonzero(rng.random(n) < 0.15):  # a wall pattern, nothing else
        ranges[i] = np.inf
        beams = list(WALLS[rng.integers(len(WALLS))])
        ranges[i, beams] = 0.01
        is_robot[i, beams] = False
    ranges[rng.random(n) < 0.4] = np.inf  # often nothing at all
    return ground, ranges, is_robot


#: Parameter sets of the parts of a merged controller (each with its own robots).
PARTS = [
    (ControllerParams(), MonaParams(), 3),
    (ControllerParams(wait_max=1.0, avoid='random-turn'), MonaParams(), 2),
    (ControllerParams(speed=0.04, alpha=3.0, wait_max=2.0, turn_min=0.5, turn_max=1.0),
     MonaParams(ir_span=2.0), 4),
    (ControllerParams(wait_max=0.5, wait_half_constant=900.0, turn_speed=0.1),
     MonaParams(ir_span=3.0, max_wheel_command=7.0), 1),
    (ControllerParams(speed=0.1, alpha=0.5, wait_max=3.0), MonaParams(ir_span=1.234), 5),
]


def make_parts(seed):
    parts, hands, first = [], [], 0
    for params, mona, n in PARTS:
        ids = range(first, first + n)
        part = SwarmController(params, mona, ids)
        part.reset(seed)
        parts.append(part)
        hands.append([Longhand(params, mona, i, seed) for i in ids])
        first += n
    return parts, hands


def outputs(controller, command):
    return (command.wheels.tobytes(), command.cleaner.tobytes(), controller.state.tobytes(),
            controller.until.tobytes(), controller.turn_direction.tobytes(),
            controller.encounters.tobytes(), command.wheels.shape, command.wheels.dtype,
            command.cleaner.dtype)


def expected(hands, ground, ranges, is_robot, now):
    """What the longhand robots ``hands`` answer, as a controller of them would show it."""
    answers = [hand.step(ground[i], ranges[i], is_robot[i], now[i])
               for i, hand in enumerate(hands)]
    wheels = np.array([wheels for wheels, _ in answers], dtype=np.float64).reshape(-1, 2)
    cleaner = np.array([cleaner for _, cleaner in answers], dtype=bool)
    return (wheels.tobytes(), cleaner.tobytes(),
            np.array([h.state for h in hands], dtype=np.int8).tobytes(),
            np.array([h.until for h in hands], dtype=np.float64).tobytes(),
            np.array([h.direction for h in hands], dtype=np.float64).tobytes(),
            np.array([h.encounters for h in hands], dtype=np.int64).tobytes(),
            (len(hands), 2), np.dtype(np.float64), np.dtype(bool))


@pytest.mark.parametrize('seed', [1, 7])
def test_lone_controllers_follow_the_rules_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    parts, hands = make_parts(seed)
    kinds = set()
    for step in range(400):
        for part, part_hands in zip(parts, hands):
            now = step * 0.25  # a lone controller takes one time for all its robots
            ground, ranges, is_robot = readings(rng, len(part_hands))
            got = outputs(part, part.step(ground, ranges, is_robot, now))
            assert got == expected(part_hands, ground, ranges, is_robot,
                                   [now] * len(part_hands)), f'step {step}'
            kinds.update(part.state.tolist())
    assert kinds == {FOLLOW, AVOID, WAIT, TURN}
    for part, part_hands in zip(parts, hands):
        assert [r.bit_generator.state for r in part.rngs] == \
            [h.rng.bit_generator.state for h in part_hands]


@pytest.mark.parametrize('seed', [2, 5])
def test_a_merged_controller_steps_each_robot_as_alone(seed):
    rng = np.random.default_rng(seed)
    alone, hands = make_parts(seed)
    merged = SwarmController.merge(make_parts(seed)[0])
    bounds = np.cumsum([0] + [n for _, _, n in PARTS])
    starts = rng.uniform(0.0, 100.0, len(PARTS)).round(2)  # each part its own clock
    avoided = 0
    for step in range(400):
        ground, ranges, is_robot = readings(rng, bounds[-1])
        now = np.repeat(starts + step * 0.25, np.diff(bounds))
        command = merged.step(ground, ranges, is_robot, now)
        assert outputs(merged, command) == expected(
            [h for part in hands for h in part], ground, ranges, is_robot, now), f'step {step}'
        for part, first, stop in zip(alone, bounds[:-1], bounds[1:]):
            rows = slice(first, stop)
            own = part.step(ground[rows], ranges[rows], is_robot[rows], float(now[first]))
            assert own.wheels.tobytes() == command.wheels[rows].tobytes()
            assert own.cleaner.tobytes() == command.cleaner[rows].tobytes()
            for name in ('state', 'until', 'turn_direction', 'encounters'):
                assert getattr(part, name).tobytes() == getattr(merged, name)[rows].tobytes()
        avoided += int((merged.state == AVOID).sum())
    assert avoided > 50
    assert [r.bit_generator.state for r in merged.rngs] == \
        [r.bit_generator.state for part in alone for r in part.rngs]


def test_equal_parameter_sets_share_their_tables():
    params, mona = ControllerParams(), MonaParams()
    parts = [SwarmController(params, mona, range(3)) for _ in range(4)]
    parts.append(SwarmController(dataclasses.replace(params, alpha=3.0), mona, range(2)))
    # Another IR range: another parameter set, but the tables do not depend on it.
    parts.append(SwarmController(params, dataclasses.replace(mona, ir_range=0.02), range(1)))
    merged = SwarmController.merge(parts)
    assert len(merged.params) == len(merged.mona) == 3
    assert merged.param_index.tolist() == [0] * 12 + [1] * 2 + [2]
    assert len(merged._commands) == 2 * len(parts[0]._commands)  # two tables
    assert merged._command_row.tolist() == (merged._command_row[0]
                                            + np.array([0] * 12 + [1] * 2 + [0])
                                            * len(parts[0]._commands)).tolist()


def test_every_ground_pair_gives_eq_1_and_eq_2():
    params, mona = ControllerParams(wait_max=17.0, alpha=1.5), MonaParams()
    controller = SwarmController(params, mona, range(256))
    beta = params.speed / mona.wheel_unit_speed
    nothing = np.full((256, K), np.inf, dtype=np.float32)
    robot_ahead = nothing.copy()
    robot_ahead[:, K // 2] = 0.01
    is_robot = np.ones((256, K), dtype=bool)
    for left in range(256):
        ground = np.stack([np.full(256, left), np.arange(256)], axis=1).astype(np.uint8)
        controller.reset(0)
        command = controller.step(ground, nothing, is_robot, 0.0)  # all follow: eq. 2
        assert command.wheels.tobytes() == gradient_wheels(
            ground, beta, params.alpha, mona.max_wheel_command).tobytes()
        command = controller.step(ground, robot_ahead, is_robot, 3.0)  # all meet: eq. 1
        assert (controller.state == WAIT).all() and not command.wheels.any()
        assert controller.until.tolist() == [
            3.0 + waiting_time(g.astype(np.float64).mean(), params) for g in ground]


def test_walls_on_both_sides_turn_away_from_the_larger_bearings():
    controller = SwarmController(ControllerParams(), MonaParams(), range(len(WALLS)))
    ranges = np.full((len(WALLS), K), np.inf, dtype=np.float32)
    for i, beams in enumerate(WALLS):
        ranges[i, list(beams)] = 0.01
    controller.step(np.zeros((len(WALLS), 2), dtype=np.uint8), ranges,
                    np.zeros((len(WALLS), K), dtype=bool), 0.0)
    assert (controller.state == AVOID).all()
    bearings = MonaParams().ir_bearings()
    for beams, direction in zip(WALLS, controller.turn_direction):
        side = sum(bearings[list(beams)])
        # right (bearings < 0) or balanced: counter-clockwise; left: clockwise
        assert direction == (-1.0 if side > 0 and not math.isclose(side, 0.0,
                                                                   abs_tol=1e-12) else 1.0)
