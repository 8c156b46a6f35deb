"""docs/interfaces.md, rule by rule, on a world-side implementation run as a black box.

Each test is one rule of the page, named after it, its docstring the page's wording, so a
failing test names the rule a world or driver breaks. Every test reads the record of the one
scenario tests/conformance/probe.py plays (conftest.py's ``run`` fixture).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

from mona_controller.controllers import DEFAULT_KIND, states_of

from geometry import beams, bearings, clean, cue_at, paper_cue, wheel_points
from probe import (
    CONTROLLED,
    POPULATION,
    POSES_0,
    POSES_2,
    ROBOT3_CLEANS_FROM,
    ROBOT3_DRIVES,
    ROBOT3_SLOW_STEP,
    ROBOT3_SPEED,
    ROBOT3_STEP0_DELAY,
    ROBOT4_CLEANER_STEP,
    ROBOT4_SILENT,
    SCRIPTED,
    stamp_of,
)

pytestmark = pytest.mark.ros

RELIABLE, BEST_EFFORT = ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT
VOLATILE, LATCHED = DurabilityPolicy.VOLATILE, DurabilityPolicy.TRANSIENT_LOCAL
STATES = ('waiting', 'running', 'finished', 'failed')


def endpoints(run, topic: str, role: str) -> list[tuple]:
    """(node, type, reliability, durability) of the implementation's ``role`` endpoints
    ('publishers' or 'subscriptions') on ``topic``, the controllers' left out."""
    found = run.scenario.graph.get(topic, {}).get(role, [])
    return [e for e in found if not e[0].startswith('mona_controller')]


def one_endpoint(run, topic: str, role: str) -> tuple:
    found = endpoints(run, topic, role)
    assert found, f'no {role[:-1]} of {topic} in the graph'
    return found[0]


# --- per robot: topics, types, QoS ------------------------------------------------------

@pytest.mark.parametrize('topic, role, msg_type', [
    ('ground', 'publishers', 'sensor_msgs/msg/Image'),
    ('proximity', 'publishers', 'sensor_msgs/msg/LaserScan'),
    ('cmd_vel', 'subscriptions', 'geometry_msgs/msg/TwistStamped'),
    ('cleaner', 'subscriptions', 'std_msgs/msg/Bool'),
    ('state', 'subscriptions', 'std_msgs/msg/UInt8')])
def test_per_robot_topics_in_namespace_mona_i_with_their_types(run, topic, role, msg_type):
    """Per robot (namespace `/mona_<i>`, i = 0 .. N-1): `ground` and `proximity` go
    world/driver -> controller, `cmd_vel`, `cleaner` and `state` controller -> world/driver,
    of the types `sensor_msgs/Image`, `sensor_msgs/LaserScan`, `geometry_msgs/TwistStamped`,
    `std_msgs/Bool`, `std_msgs/UInt8`."""
    for robot in range(POPULATION):
        name = f'/mona_{robot}/{topic}'
        node, found_type, _, _ = one_endpoint(run, name, role)
        assert found_type == msg_type, (name, node)


@pytest.mark.parametrize('topic, role, durability', [
    ('ground', 'publishers', VOLATILE), ('proximity', 'publishers', VOLATILE),
    ('cmd_vel', 'subscriptions', VOLATILE), ('cleaner', 'subscriptions', LATCHED),
    ('state', 'subscriptions', LATCHED)])
def test_per_robot_qos_reliable_and_volatile_but_the_cleaner_transient_local(
        run, topic, role, durability):
    """`ground`, `proximity`, `cmd_vel`: reliable, volatile, keep last 5; `cleaner` and
    `state`: reliable, transient local, keep last 1. (Discovery carries reliability and
    durability, not the history depth, so the depth is not checked.)"""
    for robot in range(POPULATION):
        name = f'/mona_{robot}/{topic}'
        _, _, reliability, found = one_endpoint(run, name, role)
        assert reliability == RELIABLE, name
        assert found == durability, name


# --- per robot: the readings --------------------------------------------------------------

def test_ground_is_1_by_2_mono8_left_then_right(run):
    """`ground`: height 1, width 2, `mono8`, step 2, `data = [left, right]`."""
    for robot in range(POPULATION):
        items = run.readings(robot, 'ground', 0)
        assert items, f'no ground readings of robot {robot}'
        for _, _, msg in items:
            assert (msg.height, msg.width, msg.encoding, msg.step, len(msg.data)) == \
                (1, 2, 'mono8', 2, 2), robot


def test_ground_is_the_cue_under_the_left_and_the_right_wheel(run):
    """`ground`: the cue under the left and the right wheel, 0..255 (checked before the
    first cleaning tick, on the paper's cue, at the poses of the same stamp)."""
    cue = paper_cue(run.world)
    tolerance = run.implementation.cue_tolerance
    first_tick = run.window(0)[0] + round(run.world['cleaning_period'] * 1e9)
    checked, sloped = 0, 0
    for robot in range(POPULATION):
        for _, stamp, msg in run.readings(robot, 'ground', 0):
            poses = run.poses_near(stamp)
            if poses is None or stamp >= first_tick:
                continue
            left, right = (cue_at(cue, point, run.world['cell_size'])
                           for point in wheel_points(poses[robot], run.mona['wheel_separation']))
            got = list(msg.data)
            assert abs(got[0] - left) <= tolerance and abs(got[1] - right) <= tolerance, \
                (robot, stamp, got, (left, right))
            checked += 1
            sloped += abs(left - right) > 3 * tolerance
    assert checked >= POPULATION and sloped > 0  # a left-right swap would have shown


def test_ground_and_proximity_have_the_same_stamp(run):
    """`proximity`: same stamp as `ground`."""
    for robot in range(POPULATION):
        ground = {stamp for _, stamp, _ in run.readings(robot, 'ground', 0)}
        proximity = {stamp for _, stamp, _ in run.readings(robot, 'proximity', 0)}
        assert ground and ground == proximity, robot


def test_readings_frame_is_mona_i_base_link(run):
    """`ground` and `proximity`: `frame_id = mona_<i>/base_link`."""
    for robot in range(POPULATION):
        for kind in ('ground', 'proximity'):
            frames = {msg.header.frame_id for _, _, msg in run.readings(robot, kind, 0)}
            assert frames == {f'mona_{robot}/base_link'}, (robot, kind)


def test_proximity_one_beam_per_ir_sensor_with_the_page_angles_and_range_max(run):
    """`proximity`: one beam per front IR sensor: `angle_min = -ir_span/2`,
    `angle_increment = ir_span/(ir_count-1)`, `range_max = ir_range`; `ranges` and
    `intensities` with one entry per beam."""
    count, span = run.mona['ir_count'], run.mona['ir_span']
    for robot in range(POPULATION):
        for _, _, msg in run.readings(robot, 'proximity', 0):
            assert math.isclose(msg.angle_min, -span / 2, abs_tol=1e-6), robot
            assert math.isclose(msg.angle_increment, span / (count - 1), abs_tol=1e-6), robot
            assert math.isclose(msg.range_max, run.mona['ir_range'], abs_tol=1e-6), robot
            assert len(msg.ranges) == count and len(msg.intensities) == count, robot


def compare_beams(run, episode: int):
    """Yield (robot, stamp, got ranges, got intensities, expected beams) for every proximity
    reading of ``episode`` with poses of the same stamp. A realtime implementation's reading
    may be up to its ``reading_age`` older: the beams expected are those of the newest poses
    of that span that the reading matches (else those of its stamp, to show the mismatch)."""
    angles = bearings(run.mona['ir_count'], run.mona['ir_span'])
    tolerance, ir_range = run.implementation.range_tolerance, run.mona['ir_range']
    for robot in range(POPULATION):
        for _, stamp, msg in run.readings(robot, 'proximity', episode):
            candidates = [beams(poses, robot, angles, run.mona['body_radius'], ir_range,
                                run.world['arena_side'])
                          for poses in run.poses_before(stamp, run.implementation.reading_age)]
            if not candidates:
                continue
            ranges = list(msg.ranges)
            expected = next((c for c in candidates if beams_match(ranges, c, tolerance,
                                                                   ir_range)), candidates[0])
            yield robot, stamp, ranges, list(msg.intensities), expected


def beams_match(ranges, expected, tolerance: float, ir_range: float) -> bool:
    """Whether every range is the expected one (``inf`` for nothing within range), beams on
    the rim of the range aside."""
    for got, (want, _, edge) in zip(ranges, expected):
        if abs(edge - ir_range) <= tolerance:
            continue
        if math.isinf(want) != math.isinf(got) or \
                (math.isfinite(want) and abs(got - want) > tolerance):
            return False
    return True


def test_ranges_are_measured_from_the_body_edge_inf_beyond_range_max(run):
    """`ranges[k]` = distance (m) from the **body edge** to the obstacle, `inf` = nothing
    within `range_max = ir_range` (against the poses of the same stamp)."""
    tolerance = run.implementation.range_tolerance
    compared = seen = 0
    for robot, stamp, ranges, _, expected in compare_beams(run, 0):
        for k, (got, (want, _, edge)) in enumerate(zip(ranges, expected)):
            if abs(edge - run.mona['ir_range']) <= tolerance:
                continue  # on the rim of the range: either answer is right
            if math.isinf(want):
                assert math.isinf(got), (robot, stamp, k, got, edge)
            else:
                assert abs(got - want) <= tolerance, (robot, stamp, k, got, want)
                seen += 1
            compared += 1
    assert compared and seen >= 4  # robots 0, 1, 2, 3 see something at step 0


def test_beams_run_right_to_left(run):
    """`proximity`: one beam per front IR sensor, **right to left** (robot 0 has a wall on its
    right, robot 3 one on its left, at step 0)."""
    start = run.window(0)[0]
    first = {robot: [msg for _, stamp, msg in run.readings(robot, 'proximity', 0)
                     if stamp == start] for robot in (0, 3)}
    assert first[0] and first[3], 'no proximity reading of step 0 for robots 0 and 3'
    right_wall, left_wall = list(first[0][0].ranges), list(first[3][0].ranges)
    assert math.isfinite(right_wall[0]) and math.isinf(right_wall[-1]), right_wall
    assert math.isfinite(left_wall[-1]) and math.isinf(left_wall[0]), left_wall


def test_intensities_are_1_for_a_robot_and_0_otherwise(run):
    """`intensities[k] = 1.0` where the obstacle is a robot, `0.0` otherwise."""
    robots_seen = walls_seen = 0
    for robot, stamp, ranges, intensities, expected in compare_beams(run, 0):
        for k, (value, (want, is_robot, edge)) in enumerate(zip(intensities, expected)):
            if abs(edge - run.mona['ir_range']) <= run.implementation.range_tolerance:
                continue
            assert value == (1.0 if is_robot else 0.0), (robot, stamp, k, value, ranges)
            robots_seen += is_robot
            walls_seen += math.isfinite(want) and not is_robot
    assert robots_seen and walls_seen  # robots 1 and 2 see each other, 0 and 3 a wall


# --- stepping ---------------------------------------------------------------------------

@pytest.mark.lockstep
def test_lockstep_readings_are_stamped_start_ns_plus_k_step_ns(run):
    """At step k the world publishes every robot's `ground` and `proximity` stamped
    `t_k = start_ns + k * step_ns` (k = 0 .. steps-1, every step, `control_steps` 1)."""
    start = run.window(0)[0]
    wanted = {start + k * run.step_ns for k in range(run.steps(0))}
    for robot in range(POPULATION):
        stamps = {stamp for _, stamp, _ in run.readings(robot, 'ground', 0)}
        assert stamps == wanted, (robot, sorted(wanted - stamps)[:5], sorted(stamps - wanted)[:5])


@pytest.mark.lockstep
def test_lockstep_waits_for_every_robots_cmd_vel_stamped_t_k(run):
    """Then waits until every robot has answered with a `cmd_vel` stamped `t_k` (robot 3
    answers step 20 late: no reading of step 21 may come before that answer went out)."""
    sent = run.probe.sent.get((3, ROBOT3_SLOW_STEP))
    assert sent is not None, 'robot 3 never answered its slow step'
    stamp = run.window(0)[0] + (ROBOT3_SLOW_STEP + 1) * run.step_ns
    for robot in range(POPULATION):
        arrivals = [when for when, s, _ in run.readings(robot, 'ground', 0) if s == stamp]
        assert arrivals and min(arrivals) > sent, robot


def test_a_cmd_vel_stamped_with_the_readings_it_answers_drives_the_robot(run):
    """`cmd_vel`: `twist.linear.x` (m/s), `twist.angular.z` (rad/s); `header.stamp` = **the
    stamp of the sensor readings it answers** (lockstep key). Robot 3 answers steps 40-49
    at 5 cm/s and holds still otherwise: it moves that far along its heading, no more (in
    realtime, 0.3 to 2 times as far: a command drives until the next one arrives)."""
    start = run.window(0)[0]
    first, last = ROBOT3_DRIVES[0], ROBOT3_DRIVES[-1] + 1
    # In realtime the motion shows up later (a link, a firmware, a tracker between command
    # and pose: the emulated driver's robot 3 had not moved yet 2 steps on, once in five runs).
    settle = 2 if run.implementation.mode == 'lockstep' else 16
    before, after = (run.poses_near(start + k * run.step_ns) for k in (first, last + settle))
    assert before is not None and after is not None
    moved = after[3, :2] - before[3, :2]
    heading = np.array([math.cos(before[3, 2]), math.sin(before[3, 2])])
    expected = ROBOT3_SPEED * len(ROBOT3_DRIVES) * run.step_ns / 1e9
    tolerance = 0.1 * expected + run.implementation.pose_tolerance
    forward = moved @ heading
    if run.implementation.mode == 'lockstep':
        assert abs(forward - expected) <= tolerance, (moved, expected)
    else:  # realtime: each command drives until the next arrives, as many steps as that takes
        assert 0.3 * expected <= forward <= 2.0 * expected, (moved, expected)
    assert abs(moved @ np.array([-heading[1], heading[0]])) <= tolerance, moved


@pytest.mark.lockstep
def test_cleaner_is_applied_with_the_cmd_vel_of_the_same_step(run):
    """The controller answers each pair ... first `cleaner`, then `cmd_vel`: the cleaner a
    robot publishes before its `cmd_vel` counts for that step (robot 3 turns it on with its
    answer to step 31, the last answer of the round, and step 31 reaches the first cleaning
    tick)."""
    start = run.window(0)[0]
    tick = start + (ROBOT3_CLEANS_FROM + 1) * run.step_ns
    period = round(run.world['cleaning_period'] * 1e9)
    assert (tick - start) // period > (tick - start - run.step_ns) // period  # the first tick
    events = [poses for _, stamp, poses in run.probe.cleaning if stamp == tick]
    assert events, f'no /world/cleaning at the first tick ({tick} ns)'
    robot3 = np.array(POSES_0[3][:2])
    assert any(np.hypot(*(p[:2] - robot3)) < 0.01 for p in events[0]), events[0]


@pytest.mark.lockstep
def test_step_0_waits_and_its_readings_are_repeated_until_answered(run):
    """Step 0 itself may take up to `start_timeout`, and its readings are repeated every 0.2 s
    to robots that have not answered (robot 3 answers step 0 after 2.5 s)."""
    start = run.window(0)[0]
    repeats = [when for when, stamp, _ in run.readings(3, 'ground', 0) if stamp == start]
    assert len(repeats) >= ROBOT3_STEP0_DELAY / 0.2 / 2, len(repeats)
    assert repeats[-1] - repeats[0] >= ROBOT3_STEP0_DELAY * 0.6


@pytest.mark.lockstep
def test_a_command_for_another_step_is_dropped_and_a_duplicate_applied_once(run):
    """A command stamped for another step ... is dropped and counted; a duplicate (a second
    command for the step the robot last answered) is counted and applied once (the first one
    counts). Robot 3 answers step 10 stamped 5 steps ahead, then rightly (0 m/s), then again
    at 0.05 m/s: it must not move."""
    final = run.final_status(0)
    assert final.get('dropped', 0) >= 1 and final.get('duplicates', 0) >= 1, final
    start = run.window(0)[0]
    before, after = (run.poses_at(start + k * run.step_ns) for k in (10, 12))
    assert before is not None and after is not None
    assert np.allclose(before[3], after[3], atol=run.implementation.pose_tolerance + 1e-9)


def test_a_silent_robot_is_absent_listed_and_its_readings_go_on(run):
    """A robot that misses `absent_after` steps in a row is **absent**: the world no longer
    waits for it, keeps it still and its cleaner off, and keeps publishing its readings ...
    Absent robots are listed in `/world/status` (robot 4 is silent from step 5 to 59)."""
    listed = [doc for doc in run.statuses(0) if 4 in doc.get('absent', [])]
    assert listed, 'robot 4 never listed absent'
    start = run.window(0)[0]
    silent = {start + k * run.step_ns for k in ROBOT4_SILENT}
    stamps = {stamp for _, stamp, _ in run.readings(4, 'ground', 0)}
    assert len(silent & stamps) >= len(silent) * 0.9  # readings went on while it was silent
    # Kept still while absent.
    settled = ROBOT4_SILENT[0] + run.implementation.absent_after + 2
    poses = [run.poses_at(start + k * run.step_ns) for k in (settled,
                                                             ROBOT4_SILENT[-1])]
    assert all(p is not None for p in poses)
    assert np.allclose(poses[0][4], poses[1][4], atol=run.implementation.pose_tolerance + 1e-9)


def test_an_absent_robots_cleaner_is_off(run):
    """An absent robot: the world keeps it still and its cleaner off (robot 4's last word was
    cleaner on, then it fell silent). `cleaner` is each robot's latest `Bool`: robot 3's, on
    from step 30, cleans."""
    start = run.window(0)[0]
    silent_from = start + (ROBOT4_SILENT[0] + run.implementation.absent_after) * run.step_ns
    silent_to = start + ROBOT4_SILENT[-1] * run.step_ns
    assert ROBOT4_CLEANER_STEP < ROBOT4_SILENT[0]
    saw_robot3 = False
    seen = []  # (step, the robots cleaning, or None: no poses near its stamp) for the message
    for _, stamp, poses in run.probe.cleaning:
        if not start <= stamp <= run.window(0)[1]:
            continue
        current = run.poses_near(stamp)
        near = None if current is None else sorted(
            int(np.argmin(np.hypot(*(current[:, :2] - p[:2]).T))) for p in poses)
        seen.append(((stamp - start) // run.step_ns, near))
        if near is None:
            continue
        if silent_from <= stamp <= silent_to:
            assert 4 not in near, f'absent robot 4 cleaned at {stamp}'
        if stamp > start + ROBOT3_CLEANS_FROM * run.step_ns:
            saw_robot3 |= 3 in near
    absent = [(doc.get('step'), doc.get('absent')) for doc in run.statuses(0)]
    assert saw_robot3, (f"robot 3's cleaner never showed in /world/cleaning; (step, robots "
                        f"cleaning) of its ticks: {seen}; (step, absent) of the statuses: "
                        f'{absent}')


@pytest.mark.lockstep
def test_an_absent_robot_that_answers_again_is_present(run):
    """When it answers any step of the episode again it is present from the next round on
    (robot 4 answers again from step 60). Lockstep only: in realtime a robot is absent while
    its latest answer is stale, which a loaded machine's late answers can make it again."""
    final = run.final_status(0)
    assert final.get('state') == 'finished', final
    assert 4 not in final.get('absent', []), final


def test_misses_are_counted_per_robot(run):
    """A robot that missed the deadline holds still for that step; the miss is counted per
    robot and reported in `/world/status`."""
    misses = run.final_status(0).get('misses')
    assert isinstance(misses, list) and len(misses) == POPULATION, misses
    assert misses[4] >= 1
    assert all(isinstance(m, int) and m >= 0 for m in misses)


# --- world topics -------------------------------------------------------------------------

def test_clock_is_best_effort_and_monotonic_across_episodes(run):
    """`/clock`: `rosgraph_msgs/Clock`, best effort, keep last 1 (ROS clock QoS), every
    `clock_period` of sim time; sim time monotonic across episodes."""
    _, msg_type, reliability, _ = one_endpoint(run, '/clock', 'publishers')
    assert msg_type == 'rosgraph_msgs/msg/Clock' and reliability == BEST_EFFORT
    times = [ns for _, ns in run.probe.clock_ns]
    assert times and times == sorted(times)
    low, high = run.window(0)
    during = [t for t in times if low <= t <= high]
    assert len(during) >= (high - low) / 1e9 / 0.1 / 2  # every 0.1 s of sim time, most of them
    assert max(times) >= run.window(2)[0]


def test_world_poses_index_is_robot_id_frame_world_yaw_in_quaternion(run):
    """`/world/poses`: `geometry_msgs/PoseArray`, reliable, every step, ground-truth poses,
    `frame_id = world`, index = robot id, yaw in the quaternion (step 0 = the announced
    poses)."""
    _, msg_type, reliability, _ = one_endpoint(run, '/world/poses', 'publishers')
    assert msg_type == 'geometry_msgs/msg/PoseArray' and reliability == RELIABLE
    assert ('/world/poses', 'world') in run.probe.frames
    assert not {frame for topic, frame in run.probe.frames if topic == '/world/poses'} - {'world'}
    for k, announced in ((0, POSES_0), (2, POSES_2)):
        first = run.poses_at(run.window(k)[0], last=k > 0)
        assert first is not None and first.shape == (POPULATION, 3), k
        error = np.abs(first[:, :2] - np.array(announced)[:, :2]).max()
        yaw = np.angle(np.exp(1j * (first[:, 2] - np.array(announced)[:, 2])))
        assert error <= run.implementation.pose_tolerance + 1e-9, (k, first)
        assert np.abs(yaw).max() <= 1e-6 + run.implementation.pose_tolerance * 25, (k, first)


@pytest.mark.lockstep
def test_world_poses_every_step(run):
    """`/world/poses`: every step."""
    low, high = run.window(0)
    stamps = {stamp for _, stamp, _ in run.probe.poses if low <= stamp <= high}
    assert stamps == {low + k * run.step_ns for k in range(run.steps(0) + 1)}


def received_in_episode_0(run, items):
    """The items (received first) that arrived between episode 0's announcement and the
    next one's."""
    after = run.scenario.marks.get('announced_0', 0.0)
    before = run.scenario.marks.get('announced_1', math.inf)
    return [item for item in items if after <= item[0] < before]


def test_robot_states_one_with_every_world_poses_robot_i_at_index_i(run):
    """`/world/robot_states`: `std_msgs/UInt8MultiArray`, reliable, with every `/world/poses`:
    each robot's controller state (its latest `state`; 0 before its first answer of the
    episode), robot i at index i ... the n-th `/world/robot_states` of an episode goes with
    its n-th `/world/poses`."""
    _, msg_type, reliability, _ = one_endpoint(run, '/world/robot_states', 'publishers')
    assert msg_type == 'std_msgs/msg/UInt8MultiArray' and reliability == RELIABLE
    states = received_in_episode_0(run, run.probe.robot_states)
    poses = received_in_episode_0(run, run.probe.poses)
    marks = run.scenario.marks
    assert states and len(states) == len(poses), (
        len(states), len(poses), marks, [(when, stamp) for when, stamp, _ in poses[-2:]],
        [when for when, _ in states[-2:]],
        [(when, stamp) for when, stamp, _ in run.probe.poses if stamp == run.window(0)[1]])
    assert all(len(row) == POPULATION and set(row.tolist()) <= {0, 1, 2, 3}
               for _, row in states)
    assert all(row[4] == 0 for _, row in states)  # robot 4 never said its state


@pytest.mark.lockstep
def test_robot_states_hold_each_robots_latest_state(run):
    """`/world/robot_states`: each robot's controller state (its latest `state`), robot i at
    index i (robot 3 says 2, waiting and cleaning, with its answer to step 31: the states
    with the poses of t_32 on show it, those before do not)."""
    states = received_in_episode_0(run, run.probe.robot_states)
    poses = received_in_episode_0(run, run.probe.poses)
    assert len(states) == len(poses)
    switch = run.window(0)[0] + (ROBOT3_CLEANS_FROM + 1) * run.step_ns
    for (_, row), (_, stamp, _) in zip(states, poses):
        assert row[3] == (2 if stamp >= switch else 0), (stamp, row.tolist())


def test_sources_with_every_cue_map_one_sphere_per_source(run):
    """`/world/sources`: `visualization_msgs/MarkerArray`, transient local, with `cue_map`:
    one `SPHERE` per source in name order, ns `sources`, id = its index, `text` = its name,
    8 cm across, resting on the floor at the source's centre, magenta, frame `world`, every
    marker stamped with the time it shows (here the paper's one source, `source`, at the
    arena centre)."""
    _, msg_type, _, durability = one_endpoint(run, '/world/sources', 'publishers')
    assert msg_type == 'visualization_msgs/msg/MarkerArray' and durability == LATCHED
    sources = run.maps(0, 'sources')
    assert {stamp_of(m) for m in run.maps(0)} <= {stamp_of(m) for m in sources}
    centre = run.world['arena_side'] / 2
    for msg in sources:
        (marker,) = msg.markers
        assert (marker.ns, marker.id, marker.type, marker.text, marker.header.frame_id) == \
            ('sources', 0, 2, 'source', 'world')
        assert math.isclose(marker.pose.position.x, centre, abs_tol=1e-9)
        assert math.isclose(marker.pose.position.y, centre, abs_tol=1e-9)
        assert math.isclose(marker.scale.x, 0.08, abs_tol=1e-9)
        assert math.isclose(marker.pose.position.z, marker.scale.z / 2, abs_tol=1e-9)
        assert marker.color.r > marker.color.g < marker.color.b  # magenta


def test_world_cleaning_at_cleaning_ticks_in_robot_order(run):
    """`/world/cleaning`: each cleaning tick with at least one cleaner on: poses of the robots
    that cleaned at this tick, in robot order, `frame_id = world`."""
    _, msg_type, reliability, _ = one_endpoint(run, '/world/cleaning', 'publishers')
    assert msg_type == 'geometry_msgs/msg/PoseArray' and reliability == RELIABLE
    low, high = run.window(0)
    period = round(run.world['cleaning_period'] * 1e9)
    events = [(stamp, poses) for _, stamp, poses in run.probe.cleaning if low <= stamp <= high]
    assert events, 'no cleaning event in episode 0'
    for stamp, poses in events:
        # The step that reached a multiple of cleaning_period since start_ns.
        assert (stamp - low) // period > (stamp - low - run.step_ns) // period, stamp
        current = run.poses_at(stamp)
        if current is None:
            continue
        ids = [int(np.argmin(np.hypot(*(current[:, :2] - p[:2]).T))) for p in poses]
        assert ids == sorted(ids), (stamp, ids)
    assert {f for t, f in run.probe.frames if t == '/world/cleaning'} == {'world'}


def test_cue_map_row_0_at_the_top_rebuilt_from_the_cleaning_events(run):
    """`/world/cue_map`: the cue raster as `mono8`, row 0 at the **top** (max y), 1 px =
    `cell_size`, `frame_id = world`, transient local; with the initial cue the cleaning
    events reconstruct the cue map exactly (here within mono8's rounding)."""
    _, msg_type, _, durability = one_endpoint(run, '/world/cue_map', 'publishers')
    assert msg_type == 'sensor_msgs/msg/Image' and durability == LATCHED
    low = run.window(0)[0]
    maps = run.maps(0)
    assert maps, 'no cue map of episode 0'
    last = maps[-1]
    cells = round(run.world['arena_side'] / run.world['cell_size'])
    assert (last.height, last.width, last.encoding, last.header.frame_id) == \
        (cells, cells, 'mono8', 'world')
    shown = np.frombuffer(bytes(last.data), np.uint8).reshape(cells, cells)[::-1]  # row = y
    stamp = last.header.stamp.sec * 10**9 + last.header.stamp.nanosec
    cue = paper_cue(run.world)
    for _, when, poses in run.probe.cleaning:
        if low <= when <= stamp:
            clean(cue, poses, run.world)
    cleaned = paper_cue(run.world) - cue > 4
    assert cleaned.any(), 'nothing cleaned in episode 0'
    assert np.abs(shown.astype(float) - cue).max() <= run.implementation.cue_tolerance


def test_cue_grid_is_the_same_raster_scaled_to_0_100_from_the_world_origin(run):
    """`/world/cue_grid`: `nav_msgs/OccupancyGrid`, transient local, with `cue_map`: the same
    raster scaled to 0..100, origin at the world origin."""
    grids = run.maps(0, 'cue_grid')
    maps = {(m.header.stamp.sec, m.header.stamp.nanosec): m for m in run.maps(0)}
    assert grids, 'no cue grid'
    grid = grids[-1]
    cells = round(run.world['arena_side'] / run.world['cell_size'])
    info = grid.info
    assert (info.width, info.height) == (cells, cells)
    assert math.isclose(info.resolution, run.world['cell_size'], rel_tol=1e-6)
    assert (info.origin.position.x, info.origin.position.y) == (0.0, 0.0)
    values = np.array(grid.data, dtype=float).reshape(cells, cells)  # row 0 at y = 0
    assert values.min() >= 0 and values.max() <= 100
    twin = maps.get((grid.header.stamp.sec, grid.header.stamp.nanosec))
    assert twin is not None, 'no cue map with the grid'
    image = np.frombuffer(bytes(twin.data), np.uint8).reshape(cells, cells)[::-1]
    assert np.abs(values - image.astype(float) * 100 / 255).max() <= 1.0


def colour_name(color) -> str:
    """The page's name of a marker colour: follow green, avoid orange, wait and clean red,
    turn blue."""
    r, g, b = color.r, color.g, color.b
    if b > r and b > g:
        return 'blue'
    if g > r:
        return 'green'
    return 'orange' if g > 0.35 * r else 'red'


def test_markers_one_cylinder_per_robot_coloured_by_its_controller_state(run):
    """`/world/markers`: `visualization_msgs/MarkerArray`, every `map_period`: one cylinder
    per robot (ns `robots`, id = robot) coloured by its controller state (its latest
    `state`): follow green, avoid orange, wait and clean red, turn blue (at the end of
    episode 0 robot 3 says 2, wait and clean; robot 4 never said a state: 0, follow)."""
    arrays = [msg for msg in run.maps(0, 'markers') if len(msg.markers) == POPULATION]
    assert arrays, 'no marker array with one marker per robot in episode 0'
    last = arrays[-1]
    assert all(m.type == 3 and m.ns == 'robots' for m in last.markers)  # CYLINDER
    assert sorted(m.id for m in last.markers) == list(range(POPULATION))
    poses = run.poses_near(stamp_of(last))
    assert poses is not None
    colour = {}
    for marker in last.markers:
        where = np.array([marker.pose.position.x, marker.pose.position.y])
        assert np.hypot(*(poses[marker.id, :2] - where)) < 1e-6 + \
            run.implementation.pose_tolerance, marker.id
        colour[marker.id] = colour_name(marker.color)
    # The kind's states' colours (BEECLUST's: follow green, ..., wait and clean red): robot 3
    # said code 2, robot 4 never said one (code 0).
    states = states_of(run.params.get('controller', {}).get('kind', DEFAULT_KIND))
    named = [colour_name(SimpleNamespace(r=r, g=g, b=b)) for r, g, b, _ in
             (state.colour for state in states)]
    assert colour[3] == named[2] and colour[4] == named[0], (colour, named)


def test_cue_map_and_markers_every_map_period(run):
    """`/world/cue_map` every `map_period` of sim time, `/world/markers` every `map_period`
    (episode 0: one at least in each period)."""
    low, high = run.window(0)
    period = round(run.implementation.map_period * 1e9)
    stamps = {name: sorted(stamp_of(msg) for msg in run.maps(0, name))
              for name in ('cue_map', 'markers')}
    for name, found in stamps.items():
        for k in range(1, (high - low) // period + 1):
            boundary = low + k * period
            assert any(boundary <= t < boundary + period for t in found), (name, k, found)


def test_status_each_status_period_while_running(run):
    """`/world/status`: on every change of episode state, each `status_period` of sim time
    (episode 0: one at least in each period while it runs)."""
    low, high = run.window(0)
    period = round(run.implementation.status_period * 1e9)
    times = [doc.get('time_ns') for doc in run.statuses(0)  # the last period's: 'finished'
             if doc.get('state') in ('running', 'finished')
             and isinstance(doc.get('time_ns'), int)]
    for k in range(1, (high - low) // period + 1):
        boundary = low + k * period
        assert any(boundary <= t < boundary + period for t in times), (k, times)


def test_obstacles_latched_once_and_empty_without_obstacles(run):
    """`/world/obstacles`: transient local, once, when the world starts ... No obstacles: an
    empty array (a late subscriber gets it)."""
    _, msg_type, _, durability = one_endpoint(run, '/world/obstacles', 'publishers')
    assert msg_type == 'visualization_msgs/msg/MarkerArray' and durability == LATCHED
    arrays = run.probe.latched['obstacles']
    assert arrays and all(len(msg.markers) == 0 for _, msg in arrays)


def test_status_fields_and_states(run):
    """`/world/status`: `std_msgs/String` (JSON), reliable, transient local: `{"episode",
    "state": "waiting"|"running"|"finished"|"failed", "step", "steps", "time_ns", "mode",
    "misses": [per robot], "absent": [robot ids], "dropped": n, "duplicates": n,
    "cleaning_events": n, "error": text}` (a driver may leave out what it does not count)."""
    _, msg_type, reliability, durability = one_endpoint(run, '/world/status', 'publishers')
    assert msg_type == 'std_msgs/msg/String'
    assert (reliability, durability) == (RELIABLE, LATCHED)
    types = {'step': int, 'steps': int, 'time_ns': int, 'mode': str, 'misses': list,
             'absent': list, 'dropped': int, 'duplicates': int, 'cleaning_events': int,
             'error': str}
    for _, doc in run.probe.status:
        assert isinstance(doc.get('episode'), int) and doc.get('state') in STATES, doc
        for key, kind in types.items():
            assert key not in doc or isinstance(doc[key], kind), (key, doc)
    states = [doc['state'] for doc in run.statuses(0)]
    assert 'running' in states and states[-1] == 'finished', states
    assert states.index('running') < states.index('finished')
    final = run.final_status(0)
    assert final.get('step', run.steps(0)) == run.steps(0)
    assert final.get('time_ns', run.window(0)[1]) == run.window(0)[1]


@pytest.mark.lockstep
def test_status_once_a_second_while_step_0_waits(run):
    """`/world/status`: on every change of episode state, each `status_period` of sim time,
    and once a second of wall time while the world waits (step 0, ...), so a recorder can
    tell a waiting world from a dead one (step 0 waits 2.5 s for robot 3)."""
    at_zero = [when for when, doc in run.probe.status
               if doc.get('episode') == 0 and doc.get('state') == 'running'
               and doc.get('step') == 0]
    assert len(at_zero) >= 2 and at_zero[-1] - at_zero[0] >= 1.0, at_zero


def test_status_cleaning_events_counts_the_cleaning_messages(run):
    """`cleaning_events` counts the episode's `/world/cleaning` messages so far, so a recorder
    can tell when the last one has arrived."""
    final = run.final_status(0)
    if 'cleaning_events' not in final:  # the page lets a driver leave out what it does not count
        assert not run.implementation.counts_cleaning_events, final
        return
    low, high = run.window(0)
    received = sum(low <= stamp <= high for _, stamp, _ in run.probe.cleaning)
    assert final['cleaning_events'] == received > 0


# --- episodes ---------------------------------------------------------------------------

def test_before_step_0_the_world_waits_for_every_robots_controller(run):
    """Before step 0 the world waits until every robot's controller subscribes to its readings
    and publishes `cmd_vel` (robots 3 and 4 subscribe 1 s after the announcement)."""
    listened = run.probe.listening.get(3)
    assert listened is not None
    running = [when for when, doc in run.probe.status
               if doc.get('episode') == 0 and doc.get('state') == 'running']
    assert running and running[0] >= listened, (running[:1], listened)
    assert run.readings(3, 'ground', 0) and run.readings(4, 'ground', 0)


def test_an_announcement_with_other_mona_parameters_is_rejected_naming_the_key(run):
    """The world rejects an announcement whose `world` or `mona` section differs from its own
    (`state: failed` with the reason) ... naming each key that differs (episode 1 announces
    another `mona.ir_range`)."""
    failed = [doc for doc in run.statuses(1) if doc.get('state') == 'failed']
    assert failed, run.statuses(1)
    assert 'ir_range' in failed[-1].get('error', ''), failed[-1]
    assert not any(doc.get('state') == 'running' for doc in run.statuses(1))


def test_a_new_episode_resets_at_the_announced_poses_and_time_from_start_ns(run):
    """Each episode: the world resets (cue restored, physics rebuilt at the poses) and
    measures time from its `start_ns`, the world's current sim time, so sim time never runs
    backwards."""
    final = run.final_status(2)
    assert final.get('state') == 'finished', final
    start = run.window(2)[0]
    assert start >= run.window(0)[1]
    for robot in CONTROLLED + SCRIPTED:
        stamps = sorted(stamp for _, stamp, _ in run.readings(robot, 'ground', 2))
        assert stamps and stamps[0] == start, robot
    maps = run.maps(2)
    assert maps, 'no cue map of episode 2'
    cells = round(run.world['arena_side'] / run.world['cell_size'])
    first = np.frombuffer(bytes(maps[0].data), np.uint8).reshape(cells, cells)[::-1]
    assert np.abs(first - paper_cue(run.world)).max() <= run.implementation.cue_tolerance


def test_the_shutdown_announcement_ends_the_world_with_status_0(run):
    """`{"episode": k, "shutdown": true}` when the run is over ... A node exits 0 when the
    supervisor announces the shutdown."""
    assert 'shutdown' in run.scenario.marks, run.scenario.log
    assert run.world_exit == 0, (run.world_exit, run.world_log[-2000:])
