"""teardown() ends a node process with the status the node meant, also when DDS hangs; and
deliver() gets a node's last messages to every reader before it leaves.

The hang is simulated where the real one happens (Fast DDS's ``set_listener`` spinning inside
the last ``destroy_node``, eProsima/Fast-DDS#6513): ``destroy_node`` blocks in native code
while holding the GIL, libc's ``sleep`` called through ``ctypes.PyDLL`` (which, unlike
``ctypes.CDLL``, keeps the GIL). A Python thread that would exit 99 shows the GIL really is
held: no Python-level watchdog could end such a process.
"""

from __future__ import annotations

import os
import signal
import sys
import time

import pytest

pytestmark = pytest.mark.ros

#: The watchdog of the probe, s: short, so a hung probe ends in a few seconds.
TIMEOUT = 1.5

PROBE = """
import ctypes, os, sys, threading, time
import rclpy
from mona_controller.ros.shutdown import teardown

mode, status, timeout = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
rclpy.init()
node = rclpy.create_node('teardown_probe')


def destroy_node_holding_the_gil():
    # Would end the process with 99 if any Python code could still run.
    threading.Thread(target=lambda: (time.sleep(0.3), os._exit(99)), daemon=True).start()
    ctypes.PyDLL(None).sleep(120)


if mode == 'hang':
    node.destroy_node = destroy_node_holding_the_gil
print('outputs flushed and closed', flush=True)
if mode == 'no-status':
    teardown([node])  # the call of callers that pass no status
else:
    teardown([node], timeout, exit_status=status)
print('teardown returned', flush=True)
sys.exit(status)
"""


def run_probe(processes, mode: str, status: int) -> tuple[int, float, str]:
    """Run the probe; return its exit status, its wall time and its output."""
    name = f'probe_{mode}_{status}'
    started = time.monotonic()
    probe = processes.spawn([sys.executable, '-c', PROBE, mode, str(status), str(TIMEOUT)],
                            name)
    returncode = probe.wait(20)
    return returncode, time.monotonic() - started, processes.log(name)


@pytest.mark.parametrize('status', [0, 3])
def test_a_hung_teardown_ends_with_the_intended_status_and_a_stack(processes, status):
    returncode, wall, log = run_probe(processes, 'hang', status)
    assert returncode == status, log
    assert 'Timeout (0:00:01.500000)!' in log, log
    # Where it hung: the hanging call inside teardown().
    assert 'in destroy_node_holding_the_gil' in log and 'in teardown' in log, log
    assert 'teardown returned' not in log
    # The watchdog, not the test's 20 s limit, ended it: start-up + timeout + grace.
    assert TIMEOUT < wall < 20, f'{wall:.1f} s\n{log}'


@pytest.mark.parametrize('mode, status', [('clean', 3), ('no-status', 0)])
def test_a_clean_teardown_returns_and_the_caller_exits_with_its_status(processes, mode,
                                                                      status):
    returncode, _, log = run_probe(processes, mode, status)
    assert returncode == status, log
    assert 'teardown returned' in log and 'Timeout' not in log, log


READER = """
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node('last_words_reader')
node.create_subscription(String, '/last_words', lambda msg: print('got', msg.data, flush=True),
                         QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))
print('listening', flush=True)
rclpy.spin(node)
"""


def test_deliver_waits_until_a_reader_has_the_last_message(executor, processes):
    """A node's last messages reach a reader that has not acknowledged them yet (stopped
    here, as a busy machine may keep it): deliver() waits, bounded, while it cannot answer,
    and returns once it has them."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from std_msgs.msg import String

    from mona_controller.ros.shutdown import deliver

    reader = processes.spawn([sys.executable, '-c', READER], 'reader')
    node = rclpy_node(executor)
    publisher = node.create_publisher(String, '/last_words', QoSProfile(
        depth=10, reliability=ReliabilityPolicy.RELIABLE))
    deadline = time.monotonic() + 60
    while publisher.get_subscription_count() < 1 or 'listening' not in processes.log('reader'):
        assert time.monotonic() < deadline, processes.log('reader')
        executor.spin_once(timeout_sec=0.1)
    assert deliver([node], 5.0)  # nothing sent yet: nothing to wait for
    os.kill(reader.pid, signal.SIGSTOP)
    try:
        publisher.publish(String(data='finished'))
        started = time.monotonic()
        assert not deliver([node], 1.5)  # the reader cannot answer: the bound holds
        assert 1.4 < time.monotonic() - started < 5.0
    finally:
        os.kill(reader.pid, signal.SIGCONT)
    assert deliver([node], 30.0)
    deadline = time.monotonic() + 30
    while 'got finished' not in processes.log('reader'):
        assert time.monotonic() < deadline, processes.log('reader')
        time.sleep(0.1)


def rclpy_node(executor):
    """A node of the test's own, spun by ``executor``."""
    import rclpy

    node = rclpy.create_node('last_words_writer', context=executor.context)
    executor.add_node(node)
    return node
