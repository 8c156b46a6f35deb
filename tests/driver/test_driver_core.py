"""The driver's pure cores: the world's cue and sensors at tracked poses, the IR calibration,
the wheel conversions and the fault bookkeeping of each robot's link."""

from __future__ import annotations

import numpy as np
import pytest

from mona_controller.link.frame import Frame, check
from mona_controller.link.payloads import COMMAND, TELEMETRY, Command, Telemetry
from mona_controller.mona import MonaParams, wheels_to_twist
from swarm_world.driver.calibration import ADC_MAX, CalibrationError, IrCalibration
from swarm_world.driver.fleet import Fleet
from swarm_world.driver.tracked import TrackedWorld
from swarm_world.driver.wheels import pwm_to_permille, to_permille, twist_to_wheels
from swarm_world.field import CueField
from swarm_world.params import WorldParams
from swarm_world.placement import place_robots, placement_rng
from swarm_world.sensing.ir import proximity
from swarm_world.sensing.params import SensingParams
from swarm_world.world import World

#: The simulator's sensor model of the paper (the virtual ground sensors' at tracked poses).
SENSING = SensingParams()

CASES = {
    'paper': {},
    'literal, diffusing, evaporating': {'cleaning': 'literal', 'diffusion': 1e-4,
                                        'half_life': 200.0},
}


@pytest.mark.parametrize('overrides', CASES.values(), ids=CASES.keys())
def test_ground_and_cleaning_at_tracked_poses_are_the_worlds(overrides):
    params, mona = WorldParams(**overrides), MonaParams()
    n = 12
    poses = place_robots(n, params.arena_side, mona.body_radius, placement_rng(4))
    world, tracked = World(params, mona, SENSING), TrackedWorld(params, mona, SENSING)
    world.reset(poses, seed=4)
    tracked.reset(poses, seed=4)
    rng = np.random.default_rng(0)
    record = []  # (time_ns, poses of the robots that cleaned): what /world/cleaning carries
    for _ in range(400):  # 12.8 s: twelve cleaning ticks
        linear = rng.uniform(0.0, 0.08, n)
        angular = rng.uniform(-1.0, 1.0, n)
        cleaner = rng.random(n) < 0.5
        world.step(linear, angular, cleaner)
        tracked.track(world.poses)  # the tracker sees the robots where the physics put them
        tracked.step(linear, angular, cleaner)
        if len(tracked.cleaned):
            record.append((tracked.time_ns, tracked.poses[tracked.cleaned].copy()))
        np.testing.assert_array_equal(tracked.ground_readings(), world.ground_readings())
    assert len(record) == 12
    np.testing.assert_array_equal(tracked.cue, world.cue)
    assert (tracked.cue < world.initial_cue).any()  # the robots cleaned
    # The cleaning record rebuilds the cue bit for bit, as a bag's analysis does.
    replica = CueField(params, mona, SENSING)
    for time_ns, cleaned in record:
        replica.clean_at(time_ns, cleaned)
    replica.advance_to(tracked.time_ns)
    np.testing.assert_array_equal(replica.cue, tracked.cue)


def test_a_held_robot_is_stopped_and_does_not_clean():
    params, mona = WorldParams(), MonaParams()
    poses = np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0]])
    tracked = TrackedWorld(params, mona, SENSING)
    tracked.reset(poses)
    tracked.held = np.array([False, True])
    for _ in range(40):  # past the first cleaning tick at 1 s
        tracked.step(np.array([0.05, 0.05]), np.array([0.2, 0.2]), np.array([True, True]))
    linear, angular = tracked.commanded
    assert linear.tolist() == [0.05, 0.0] and angular.tolist() == [0.2, 0.0]
    assert tracked.cleaning.tolist() == [True, False]
    assert tracked.cue[200, 200] == tracked.initial_cue[200, 200]  # robot 1's cell untouched
    assert tracked.cue[100, 100] < tracked.initial_cue[100, 100]


def test_a_tracker_dropout_keeps_the_last_pose_and_headings_are_wrapped():
    tracked = TrackedWorld(WorldParams(), MonaParams(), SENSING)
    tracked.reset(np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0]]))
    valid = tracked.track(np.array([[1.5, 1.2, 4.0], [np.nan, np.nan, np.nan]]))
    assert valid.tolist() == [True, False]
    assert tracked.poses[1].tolist() == [2.0, 2.0, 0.0]
    assert tracked.poses[0, 2] == pytest.approx(4.0 - 2 * np.pi)
    assert tracked.track(np.array([[1.0, 1.0, 0.0]])).tolist() == [True, False]  # short array


def test_robot_and_wall_are_told_apart_from_the_tracked_poses():
    params, mona = WorldParams(), MonaParams()
    poses = np.array([
        [1.0, 1.0, 0.0],  # 0: robot 1 ahead, 1 cm between the bodies
        [1.09, 1.0, np.pi],  # 1: faces robot 0
        [0.06, 2.0, np.pi],  # 2: faces the west wall, 2 cm away
        [2.0, 0.5, 0.0],  # 3: nothing near
    ])
    tracked = TrackedWorld(params, mona, SENSING)
    tracked.reset(poses)
    ranges, is_robot = proximity(poses, mona.body_radius, mona.ir_bearings(), mona.ir_range,
                                 params.arena_side)
    calibration = tracked.calibration
    for i in range(4):  # the telemetry the robots would send
        tracked.set_ir(i, calibration.to_adc(ranges[i]))
    seen, flags = tracked.ir_readings()
    assert np.isfinite(seen[0, 2]) and flags[0, 2] and flags[1, 2]
    assert np.isfinite(seen[2, 2]) and not flags[2].any()
    assert not np.isfinite(seen[3]).any() and not flags[3].any()
    # Where the beams see something, the flags are the geometry's own.
    np.testing.assert_array_equal(flags[np.isfinite(seen)], is_robot[np.isfinite(seen)])
    np.testing.assert_allclose(seen[np.isfinite(ranges)], ranges[np.isfinite(ranges)],
                               atol=1e-4)  # the ADC's resolution: 0.03 mm per count here
    # A tracker error of 1.5 cm: robot 1 seen 1.5 cm off still counts as a robot.
    tracked.track(poses + np.array([[0, 0, 0], [0.015, 0, 0], [0, 0, 0], [0, 0, 0]]))
    assert tracked.ir_readings()[1][0, 2]


def test_the_calibration_maps_both_ways_and_refuses_a_bad_table():
    calibration = IrCalibration()
    ranges = np.linspace(0.0, 0.0299, 200)
    back = calibration.to_ranges(calibration.to_adc(ranges))
    assert np.all(np.isfinite(back))
    np.testing.assert_allclose(back, ranges, atol=1e-4)
    assert calibration.to_adc([np.inf, 0.05]).tolist() == [ADC_MAX, ADC_MAX]
    assert np.isinf(calibration.to_ranges([ADC_MAX, 1000])).all()
    adc = calibration.to_adc(ranges)
    mv = calibration.millivolts(adc)
    np.testing.assert_array_equal(mv * 1023 // 3300, adc)  # simavr's conversion floors back
    with pytest.raises(CalibrationError, match='both increase'):
        IrCalibration((0.0, 500.0, 0.01, 400.0))
    with pytest.raises(CalibrationError, match='pairs'):
        IrCalibration((0.0, 500.0, 0.01))


def test_wheel_conversions_invert_the_controllers_and_the_firmwares():
    mona = MonaParams()
    wheels = np.array([[6.0, 4.0], [-3.0, 3.0], [10.0, 10.0]])
    linear, angular = wheels_to_twist(wheels, mona)
    for (left, right), v, w in zip(wheels, linear, angular):
        got = twist_to_wheels(v, w, mona.wheel_separation)
        assert got == pytest.approx((left * mona.wheel_unit_speed,
                                     right * mona.wheel_unit_speed))
    assert to_permille(0.12, 0.24) == 500 and to_permille(-1.0, 0.24) == -1000
    assert to_permille(float('nan'), 0.24) == 0
    for command in range(-1000, 1001, 7):  # the firmware's deadband map, then back
        pwm = 0 if command == 0 else 25 + round(abs(command) * 230 / 1000)
        assert abs(pwm_to_permille(pwm, command < 0) - command) <= 1000 / 230 / 2 + 1e-9


def telemetry(robot: int, seq: int, nonce: int, ir=(1023,) * 5, battery=3700) -> Frame:
    payload = Telemetry(tuple(ir), 0, 0, battery, 0, 0, 0).encode()
    return Frame(robot, seq, nonce, TELEMETRY, payload)


def test_the_fleet_holds_silent_and_lost_robots_and_counts_every_fault():
    fleet = Fleet(2, host_nonce=0xBEEF, silent_after=0.5, tracker_timeout=0.5)
    assert fleet.held(0.0).tolist() == [True, True]  # nothing heard, nothing seen yet
    assert fleet.take_events() == ['robot 0 held: no telemetry and no tracked pose yet',
                                   'robot 1 held: no telemetry and no tracked pose yet']
    fleet.held(0.05)
    assert fleet.take_events() == []  # said once
    for seq in range(3):
        assert fleet.receive(telemetry(0, seq, 7), 0.1 + seq * 0.05) is not None
        fleet.receive(telemetry(1, seq, 9), 0.1 + seq * 0.05)
    assert fleet.receive(telemetry(0, 2, 7), 0.25) is None  # a duplicate is not used
    fleet.receive(telemetry(0, 5, 7), 0.3)  # two frames lost
    fleet.tracked(np.array([True, True]), 0.3)
    assert fleet.held(0.4).tolist() == [False, False]
    # Robot 1 goes silent; the tracker loses robot 0.
    fleet.receive(telemetry(0, 6, 7), 0.9)
    fleet.tracked(np.array([False, True]), 0.9)
    assert fleet.held(1.0).tolist() == [True, True]
    fleet.count_held(np.array([True, True]))
    # Robot 1 reboots (a new nonce, its sequence from 0) and is heard again; robot 0 is seen.
    assert fleet.receive(telemetry(1, 0, 10), 1.1) is not None
    assert fleet.receive(telemetry(1, 2, 9), 1.1) is None  # late, from before the reboot
    fleet.tracked(np.array([True, True]), 1.1)
    fleet.receive(telemetry(0, 7, 7), 1.1)
    assert fleet.held(1.2).tolist() == [False, False]
    rows = fleet.counters()
    assert (rows[0]['lost'], rows[0]['duplicated'], rows[0]['dropouts']) == (2, 1, 1)
    assert (rows[1]['silences'], rows[1]['reboots'], rows[1]['stale']) == (1, 1, 1)
    assert rows[0]['held_steps'] == rows[1]['held_steps'] == 1
    events = ' | '.join(fleet.take_events())
    assert 'robot 1 silent' in events and 'robot 0 lost by the tracker' in events
    assert 'robot 1 rebooted' in events and fleet.take_events() == []


def test_commands_carry_the_host_nonce_and_a_rising_sequence():
    fleet = Fleet(1, host_nonce=0x1234, silent_after=0.5, tracker_timeout=0.5)
    first, second = fleet.command(0, 500, -20, True), fleet.command(0, 0, 0, False)
    a, b = check(first), check(second)
    assert (a.kind, a.nonce, a.robot) == (COMMAND, 0x1234, 0)
    assert b.seq == a.seq + 1
    assert Command.decode(a.payload) == Command(500, -20, True)


def test_a_low_battery_is_counted_once_and_logged_and_the_robot_goes_on():
    fleet = Fleet(1, host_nonce=1, silent_after=0.5, tracker_timeout=0.5, battery_low=3400)
    fleet.tracked(np.array([True]), 0.0)
    fleet.held(0.0)  # tracked, but no telemetry yet: held, and said so
    assert fleet.take_events() == ['robot 0 held: no telemetry yet']
    for seq, mv in enumerate((3800, 3390, 3380, 3390)):
        fleet.receive(telemetry(0, seq, 7, battery=mv), 0.05 * seq)
    assert fleet.held(0.2).tolist() == [False]
    row = fleet.counters()[0]
    assert (row['low_battery'], row['battery_mv']) == (1, 3390)
    assert fleet.take_events() == ['robot 0 battery low: 3390 mV < 3400 mV',
                                   'robot 0 back: telemetry and pose']
