"""The launcher's check of what a ROS node reads (swarm_supervisor.system.ros_yaml) held to rcl
itself: for each parameter file (and -p value) below, the check refuses it exactly when rcl
refuses it or gives a node other values than PyYAML gives the embedded runner."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
import rclpy
import yaml
from rclpy.context import Context
from rclpy.node import Node

from mona_controller.ros.ros_params import _plain
from mona_controller.schema import ParameterError
from swarm_supervisor.system.ros_yaml import check_ros_file, check_ros_override

#: Parameter bodies (under /**: ros__parameters:), each read by PyYAML and by rcl.
BODIES = {
    'plain': 'episode: {population: 3, duration: 2.0, seed: 4}',
    'floats': 'study: {speeds: [0.04, 1.0]}',
    'integers': 'study: {populations: [10, 20]}',
    'mixed-numbers': 'study: {speeds: [0.04, 1]}',
    'string-and-numbers': 'world: {obstacles: {box: [rect, 1.0, 1.0, 1.2, 1.2]}}',
    'booleans-and-numbers': 'x: [true, 1]',
    'list-of-lists': 'x: [[1.0, 2.0], [3.0, 4.0]]',
    'list-of-mappings': 'x: [{a: 1}]',
    'empty-list': 'x: []',
    'empty-mapping': 'world: {sources: {}}',
    'no-value': 'x:',
    'tilde': 'x: ~',
    'null': 'x: null',
    'underscore': 'x: 1_000',
    'sexagesimal': 'x: 1:30',
    'y': 'x: y',
    'quoted-y': "x: 'y'",
    'yes': 'x: yes',
    'exponent': 'x: 1e3',
    'signed-exponent': 'x: 1.0e+3',
    'octal': 'x: 010',
    'eight': 'x: 08',
    'hex': 'x: 0x10',
    'binary': 'x: 0b11',
    'huge': 'x: 99999999999999999999',
    'dot-five': 'x: .5',
    'one-dot': 'x: 1.',
    'inf': 'x: .inf',
    'bare-inf': 'x: inf',
    'date': 'x: 2024-01-01',
    'path': 'world: {cue_file: maps/leak v2.png}',
    'alias': 'x: &a 1.5\n    z: *a',
    'dotted-key': 'study: {factors: {mona.ir_range: [0.02, 0.05]}}',
    'block-list': 'x:\n      - 1.0\n      - 2.0',
}
#: -p values, each read by PyYAML (the launcher's check of the parameters) and by rcl.
OVERRIDES = ['x:=[0.04, 1]', 'x:=[0.04, 1.0]', 'x:=1_000', 'x:=8', 'x:="y"', 'x:=y',
             'x:=maps/a b.png']


def _flat(document: Any, prefix: str = '') -> dict[str, Any]:
    """PyYAML's values as dotted parameter names (an empty mapping is a value of its own)."""
    if isinstance(document, dict) and document:
        flat: dict[str, Any] = {}
        for key, value in document.items():
            flat.update(_flat(value, f'{prefix}{key}.'))
        return flat
    return {prefix[:-1]: document}


def _same(ours: Any, theirs: Any) -> bool:
    if isinstance(ours, list) and isinstance(theirs, list):
        return len(ours) == len(theirs) and all(map(_same, ours, theirs))
    if type(ours) is not type(theirs):
        return False
    if isinstance(ours, float) and math.isnan(ours):
        return math.isnan(theirs)
    return bool(ours == theirs)


def _rcl_reads_otherwise(args: list[str], expected: dict[str, Any]) -> bool:
    """Whether rcl refuses ``args`` or gives a node other values than ``expected``."""
    context = Context()
    try:
        rclpy.init(args=['probe', '--ros-args', *args], context=context)
    except rclpy._rclpy_pybind11.RCLError:
        return True
    try:
        node = Node('probe', context=context)
        try:
            got = {name: _plain(parameter.value)
                   for name, parameter in node._parameter_overrides.items()}
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
    return got.keys() != expected.keys() or not all(
        _same(expected[name], got[name]) for name in expected)


@pytest.mark.parametrize('name', list(BODIES))
def test_the_check_refuses_a_file_exactly_when_rcl_reads_it_otherwise(name, tmp_path: Path,
                                                                      ros_env):
    path = tmp_path / 'parameters.yaml'
    path.write_text('/**:\n  ros__parameters:\n    ' + BODIES[name] + '\n')
    expected = _flat(yaml.safe_load(path.read_text())['/**']['ros__parameters'])
    try:
        check_ros_file(path)
        refused = ''
    except ParameterError as error:
        refused = str(error)
    assert bool(refused) == _rcl_reads_otherwise(['--params-file', str(path)], expected), \
        refused or 'accepted'
    if refused:  # one line, naming the file and a line
        assert '\n' not in refused and refused.startswith(f'{path} line ')


@pytest.mark.parametrize('text', OVERRIDES)
def test_the_check_refuses_an_override_exactly_when_rcl_reads_it_otherwise(text, ros_env):
    name, _, value = text.partition(':=')
    try:
        check_ros_override(text)
        refused = ''
    except ParameterError as error:
        refused = str(error)
    expected = {name: yaml.safe_load(value)}
    assert bool(refused) == _rcl_reads_otherwise(['-p', text], expected), refused or 'accepted'
