"""A bad parameter stops a node at start-up: exit status 2 and a message naming the parameter
and what is allowed. Real processes, started at once (they only differ in their arguments)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

BIN = Path(sys.executable).parent
CONTROLLER = [str(BIN / 'mona_controller_node'), '--robots', '0', '--ros-args']

CASES = {
    # rclpy rejects the override against the declared range; we say it the schema's way
    'controller_range': (CONTROLLER + ['-p', 'controller.speed:=5.0'],
                         'controller.speed = 5.0 is out of range: allowed [0, 1] m/s'),
    'controller_type': (CONTROLLER + ['-p', 'controller.beeclust.alpha:=fast'],
                        "controller.beeclust.alpha = 'fast': expected a number"),
    'controller_unknown': (CONTROLLER + ['-p', 'controller.sped:=0.1'],
                           'unknown parameter controller.sped; known in controller: '
                           'beeclust.alpha'),
    # a renamed key still works (tests/ros/test_controller_node.py), but not beside its new one
    'controller_renamed_twice': (CONTROLLER + ['-p', 'controller.alpha:=3.0', '-p',
                                               'controller.beeclust.alpha:=3.0'],
                                 'controller.alpha and controller.beeclust.alpha are both '
                                 'given: give controller.beeclust.alpha only'),
    'controller_no_id': ([str(BIN / 'mona_controller_node')], 'robot_id is not set'),
    'world_choice': ([str(BIN / 'world_node'), '--ros-args', '-p', 'mode:=fast'],
                     "mode = 'fast' is not allowed: one of 'lockstep', 'realtime'"),
    'supervisor_empty': ([str(BIN / 'supervisor_node'), '--ros-args', '-p',
                          'episode.population:=0'],
                         'episode.population = 0 is out of range for a ros run: allowed '
                         '[1, 100000] robots'),
    'supervisor_fraction': ([str(BIN / 'supervisor_node'), '--ros-args', '-p',
                             'episode.population:=2.5'],
                            'episode.population = 2.5: expected a whole number'),
}


def test_bad_parameters_fail_at_start_with_a_clear_message(processes):
    started = {name: processes.spawn(command, name) for name, (command, _) in CASES.items()}
    for name, process in started.items():
        status = process.wait(120)
        log = processes.log(name)
        assert status == 2, f'{name}: exit {status}\n{log}'
        assert CASES[name][1] in log, f'{name}:\n{log}'
        assert 'Traceback' not in log, log
