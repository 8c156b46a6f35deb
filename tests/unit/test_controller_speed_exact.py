"""The vectorised controller, lone and merged, against its rules written out robot by robot.

SwarmController.step computes its robots' behaviour with lookup tables, one code per robot
and Python for the few robots whose state changes; a merged controller steps the robots of
several episodes, with different parameters, at once. Each robot must compute bit for bit
what the reference (mona_controller.controllers.reference.Longhand) computes for it alone: wheels,
cleaner, state, until, turn direction, encounters, and the same draws from its own generator;
check_controller compares them all, every step, and names the first difference. (That a
merged controller equals its parts stepped alone is tests/unit/test_controllers.py.)
"""

import dataclasses
import math

import numpy as np
import pytest

from mona_controller.controllers.beeclust import (
    AVOID,
    FOLLOW,
    TURN,
    WAIT,
    BeeclustParams,
    SwarmController,
    gradient_wheels,
    waiting_time,
)
from mona_controller.controllers.params import ControllerParams
from mona_controller.controllers.reference import check_controller
from mona_controller.mona import MonaParams

K = MonaParams().ir_count

#: Wall beams (right to left) whose bearings sum to exactly zero, on one side, on both.
WALLS = [(0, 4), (1, 3), (0, 1, 3, 4), (2,), (0, 2, 4), (0,), (4,), (0, 1), (3, 4), (1, 2, 3)]

#: Parameter sets of the parts of a merged controller (each with its own robots).
PARTS = [
    (ControllerParams(), MonaParams(), 3),
    (ControllerParams.of(BeeclustParams(wait_max=1.0, avoid='random-turn')), MonaParams(), 2),
    (ControllerParams.of(BeeclustParams(alpha=3.0, wait_max=2.0, turn_min=0.5, turn_max=1.0),
                         speed=0.04), MonaParams(ir_span=2.0), 4),
    (ControllerParams.of(BeeclustParams(wait_max=0.5, wait_half_constant=900.0,
                                        turn_speed=0.1)),
     MonaParams(ir_span=3.0, max_wheel_command=7.0), 1),
    (ControllerParams.of(BeeclustParams(alpha=0.5, wait_max=3.0), speed=0.1),
     MonaParams(ir_span=1.234), 5),
    # Turning in place at the robot's own speed, and at the wheels' top command.
    (ControllerParams.of(BeeclustParams(wait_max=2.0, turn_at='speed'), speed=0.06),
     MonaParams(), 3),
    (ControllerParams.of(BeeclustParams(wait_max=2.0, avoid='random-turn', turn_at='full')),
     MonaParams(max_wheel_command=8.0), 2),
]


def make_parts():
    parts, first = [], 0
    for params, mona, n in PARTS:
        parts.append(SwarmController(params, mona, range(first, first + n)))
        first += n
    return parts


@pytest.mark.parametrize('seed', [1, 7])
def test_lone_controllers_follow_the_rules_bit_for_bit(seed):
    kinds = set()
    for k, part in enumerate(make_parts()):
        # a lone controller takes one time (a float) for all its robots
        trace = check_controller(part, seed=seed, steps=400, readings_seed=[seed, k])
        kinds.update(trace.ravel().tolist())
    assert kinds == {FOLLOW, AVOID, WAIT, TURN}


@pytest.mark.parametrize('seed', [2, 5])
def test_a_merged_controller_steps_each_robot_as_alone(seed):
    starts = np.random.default_rng(seed).uniform(0.0, 100.0, len(PARTS)).round(2)
    # each part its own clock: now is per robot
    trace = check_controller(lambda: SwarmController.merge(make_parts()), seed=seed,
                             steps=400, starts=np.repeat(starts, [n for _, _, n in PARTS]))
    assert (trace == AVOID).sum() > 50


def test_a_wait_is_over_at_the_time_it_ends():
    # Waits of 0 s, and a clock that stands still: a wait is over when now >= until.
    params = ControllerParams.of(BeeclustParams(wait_max=0.0))
    trace = check_controller(SwarmController(params, MonaParams(), range(10)), period=0.0,
                             steps=40)
    assert (trace == TURN).any()


class Float32Until(SwarmController):
    """BEECLUST that keeps the ends of waits and turns in float32 (a tempting shortcut)."""

    def step(self, ground, ranges, is_robot, now):
        command = super().step(ground, ranges, is_robot, now)
        self.until[:] = self.until.astype(np.float32)
        return command


def test_a_difference_is_named_by_step_robot_and_field():
    with pytest.raises(AssertionError,
                       match=r'^step \d+, robot 1\d \(row \d\): until is [\d.]+, the reference '
                             r'has [\d.]+$'):
        check_controller(Float32Until(ControllerParams(), MonaParams(), range(10, 15)))


def test_equal_parameter_sets_share_their_tables():
    params, mona = ControllerParams(), MonaParams()
    parts = [SwarmController(params, mona, range(3)) for _ in range(4)]
    parts.append(SwarmController(ControllerParams.of(BeeclustParams(alpha=3.0)), mona, range(2)))
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
    own, mona = BeeclustParams(wait_max=17.0, alpha=1.5), MonaParams()
    params = ControllerParams.of(own)
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
            ground, beta, own.alpha, mona.max_wheel_command).tobytes()
        command = controller.step(ground, robot_ahead, is_robot, 3.0)  # all meet: eq. 1
        assert (controller.state == WAIT).all() and not command.wheels.any()
        assert controller.until.tolist() == [
            3.0 + waiting_time(g.astype(np.float64).mean(), own) for g in ground]


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


@pytest.mark.parametrize('turn_at, wheel_speed', [('turn_speed', 0.04), ('speed', 0.06),
                                                  ('full', 8.0 * 0.04 / 3.0)])
def test_a_turn_lasts_its_angle_over_the_rate_its_wheels_give(turn_at, wheel_speed):
    mona = MonaParams(max_wheel_command=8.0)
    params = ControllerParams.of(BeeclustParams(wait_max=0.0, turn_at=turn_at), speed=0.06)
    controller = SwarmController(params, mona, [0])
    ground = np.zeros((1, 2), dtype=np.uint8)
    near = np.full((1, K), np.inf, dtype=np.float32)
    near[0, 2] = 0.01
    controller.step(ground, near, np.ones((1, K), dtype=bool), 0.0)  # meets: a 0 s wait
    command = controller.step(ground, np.full((1, K), np.inf, dtype=np.float32),
                              np.zeros((1, K), dtype=bool), 0.0)  # the wait is over: turn
    assert controller.state[0] == TURN
    spin = abs(command.wheels[0, 1]) * mona.wheel_unit_speed
    assert spin == pytest.approx(wheel_speed)
    angle = controller.until[0] * 2 * spin / mona.wheel_separation
    assert np.pi / 2 <= angle <= np.pi
