"""Fuzz: whatever a driver sends as ground and proximity messages, the controller node's
conversion either rejects the message or hands the core readings a healthy sensor could give,
and the commands stay finite and within the wheel limits. (Message types only, no DDS.)"""

from __future__ import annotations

import array
import math

import numpy as np
from geometry_msgs.msg import TwistStamped
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from sensor_msgs.msg import Image, LaserScan

from mona_controller.controllers import ControllerParams, SwarmController
from mona_controller.mona import MonaParams, wheels_to_twist
from mona_controller.ros.messages import (
    ReadingError,
    fill_twist,
    ground_from_image,
    proximity_from_scan,
)

MONA = MonaParams()
K = MONA.ir_count
any_float = st.floats(allow_nan=True, allow_infinity=True, width=32)
beams = st.one_of(st.lists(any_float, min_size=K, max_size=K),
                  st.lists(any_float, max_size=2 * K))


@st.composite
def scans(draw) -> LaserScan:
    msg = LaserScan(range_max=draw(st.one_of(st.just(MONA.ir_range), any_float)))
    msg.ranges = array.array('f', draw(beams))
    msg.intensities = array.array('f', draw(st.one_of(st.just(list(msg.ranges)), beams)))
    return msg


@st.composite
def images(draw) -> Image:
    width = draw(st.sampled_from([2, 2, 2, 1, 3]))
    data = draw(st.one_of(st.binary(min_size=width, max_size=width), st.binary(max_size=4)))
    return Image(height=1, width=width, step=width, data=array.array('B', data),
                 encoding=draw(st.sampled_from(['mono8', 'mono8', 'rgb8', ''])))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(steps=st.lists(st.tuples(images(), scans(), st.floats(0.0, 1e4)), min_size=1,
                      max_size=8))
def test_any_message_gives_a_rejection_or_safe_finite_commands(steps):
    controller = SwarmController(ControllerParams(), MONA, [0])
    controller.reset(3)
    twist = TwistStamped()
    now = 0.0
    for image, scan, dt in steps:
        now += dt
        try:
            ground = ground_from_image(image).reshape(1, 2)
            ranges, is_robot, _ = proximity_from_scan(scan, K)
        except ReadingError:
            event('rejected')
            continue  # the node answers a stop for unusable readings
        event('stepped')
        assert ranges.dtype == np.float32 and ranges.shape == (K,)
        assert not np.isnan(ranges).any() and (ranges >= 0).all()
        assert is_robot.dtype == bool
        command = controller.step(ground, ranges.reshape(1, -1), is_robot.reshape(1, -1), now)
        assert np.isfinite(command.wheels).all()
        assert (np.abs(command.wheels) <= MONA.max_wheel_command).all()
        linear, angular = wheels_to_twist(command.wheels, MONA)
        assert fill_twist(twist, 1, float(linear[0]), float(angular[0]))
        assert math.isfinite(twist.twist.linear.x) and math.isfinite(twist.twist.angular.z)


def test_healthy_readings_pass_unchanged():
    msg = LaserScan(range_max=MONA.ir_range)
    values = np.array([0.0, 0.01, np.inf, 0.03, np.inf], dtype=np.float32)
    msg.ranges = array.array('f', values.tobytes())
    msg.intensities = array.array('f', [1.0, 0.0, 0.0, 1.0, 0.0])
    ranges, is_robot, note = proximity_from_scan(msg, K)
    assert note == '' and np.array_equal(ranges, values)
    assert is_robot.tolist() == [True, False, False, True, False]


def test_non_finite_commands_become_a_stop():
    twist = TwistStamped()
    assert not fill_twist(twist, 5, math.nan, 1.0)
    assert (twist.twist.linear.x, twist.twist.angular.z) == (0.0, 0.0)
