"""spin_until (mona_controller.ros.spinning), how every node process spins: it delivers to a
subscription created while it spins (the controller subscribes to its readings from a timer,
once its answers can be delivered), returns when asked, and a signal ends it at once.

Each case runs in a process of its own: rclpy's signal handlers and context are per process.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.ros

PROBE = """
import sys, time
import rclpy
from rclpy.clock import Clock, ClockType
from std_msgs.msg import UInt8
from mona_controller.ros.shutdown import STOPPED
from mona_controller.ros.spinning import spin_until

rclpy.init()
node = rclpy.create_node('spinning_probe')
got = []
publisher = node.create_publisher(UInt8, 'probe', 10)
node.create_timer(0.02, lambda: publisher.publish(UInt8(data=len(got) % 256)))


def subscribe_late():
    node.destroy_timer(late)
    node.create_subscription(UInt8, 'probe', lambda msg: got.append(msg.data), 10)
    print('subscribed', flush=True)


late = node.create_timer(0.2, subscribe_late, clock=Clock(clock_type=ClockType.STEADY_TIME))
wanted = int(sys.argv[1])  # 0: until a signal
try:
    spin_until([node], lambda: wanted and len(got) >= wanted)
    print(f'returned with {len(got)}', flush=True)
except STOPPED as error:
    print(f'stopped by {type(error).__name__}', flush=True)
"""


def probe(ros_env: dict[str, str], wanted: int) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, '-c', PROBE, str(wanted)], env=ros_env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def test_a_late_subscription_is_served_and_spin_until_returns_when_done(ros_env):
    process = probe(ros_env, 20)
    out, _ = process.communicate(timeout=60)
    assert process.returncode == 0, out
    assert 'subscribed' in out and 'returned with 20' in out, out


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_a_signal_ends_spin_until_at_once(ros_env, sig):
    process = probe(ros_env, 0)
    assert process.stdout is not None
    assert process.stdout.readline().strip() == 'subscribed'  # spinning, not starting
    process.send_signal(sig)
    sent = time.monotonic()
    out, _ = process.communicate(timeout=30)
    # Far from a hang (the executor polls every 1 s; a machine crowded by a start-up storm
    # beside the test can add seconds to the exit); a stopped spin is no error.
    assert time.monotonic() - sent < 20, out
    assert process.returncode == 0 and 'stopped by' in out, out
