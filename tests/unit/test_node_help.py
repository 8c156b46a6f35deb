"""``--help`` of every node executable: a usage with the description, the parameters and the
exit statuses, printed before rclpy.init (no node starts), exit 0, in a few seconds; the ROS
arguments are not the node's own (mona_controller.node_help)."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from mona_controller.node_help import own_args

BIN = Path(sys.executable).parent
NODES = {'world_node': [str(BIN / 'world_node')],
         'driver_node': [str(BIN / 'driver_node')],
         'metrics_node': [str(BIN / 'metrics_node')],
         'supervisor_node': [str(BIN / 'supervisor_node')],
         'mona_controller_node': [str(BIN / 'mona_controller_node')],
         'live_node': [sys.executable, '-m', 'swarm_supervisor.system.ros.live_node']}


@pytest.mark.parametrize('name', list(NODES))
def test_help_prints_the_usage_and_starts_no_node(name: str, tmp_path: Path):
    began = time.monotonic()
    # ROS_LOG_DIR: rclpy.init would write its log file there; --help must not get that far.
    done = subprocess.run([*NODES[name], '--help'], capture_output=True, text=True,
                          timeout=60, env={'PATH': str(BIN), 'ROS_LOG_DIR': str(tmp_path)})
    took = time.monotonic() - began
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f'usage: {name}')
    assert 'exit status: 0 ' in done.stdout and '2 a bad parameter' in done.stdout
    assert '-p ' in done.stdout and '--ros-args' in done.stdout
    assert not list(tmp_path.iterdir())  # rclpy.init never ran
    assert took < 10, took


def test_a_bad_option_of_a_node_exits_2():
    done = subprocess.run([*NODES['mona_controller_node'], '--robot', '3'],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and 'unrecognized arguments: --robot 3' in done.stderr


@pytest.mark.parametrize('argv, own', [
    ([], []),
    (['--robots', '0-3', '--ros-args', '--params-file', 'f.yaml', '-p', 'a:=1'],
     ['--robots', '0-3']),
    (['--ros-args', '-p', 'a:=1', '--', '--help'], ['--help']),
    (['--ros-args', '-p', 'help:=1'], []),
])
def test_own_args_skip_the_ros_arguments(argv, own):
    assert own_args(argv) == own
