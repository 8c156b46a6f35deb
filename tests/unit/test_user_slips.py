"""Slips a user makes in units, shapes and sizes get a message that says the fix:
a CLI speed in m/s, an m/s parameter in cm/s, a flat parameter file, too many robots."""

from __future__ import annotations

import argparse
import math
import re

import pytest

from mona_controller.schema import ParameterError
from swarm_supervisor.cli.arguments import speed_cm_s
from swarm_supervisor.config import SwarmConfig, load_config
from swarm_world.placement import MAX_COVERAGE, PlacementError, place_robots, placement_rng

RADIUS = 0.04


@pytest.mark.parametrize('text, value', [('8', 8.0), ('0.5', 0.5), ('100', 100.0)])
def test_a_cli_speed_in_cm_per_s_is_taken(text, value):
    assert speed_cm_s(text) == value


@pytest.mark.parametrize('text, message', [
    ('0.08', '0.08 cm/s looks like m/s: give cm/s, e.g. --speed 8'),
    ('0.4', '0.4 cm/s looks like m/s: give cm/s, e.g. --speed 40'),
    ('0', 'the robots would not move'),
    ('-1', 'out of range'),
    ('200', 'out of range'),
    ('fast', "'fast' is not a number"),
])
def test_a_cli_speed_that_is_not_cm_per_s_is_refused(text, message):
    with pytest.raises(argparse.ArgumentTypeError, match=message):
        speed_cm_s(text)


def test_an_m_per_s_parameter_out_of_range_hints_the_unit():
    with pytest.raises(ParameterError, match=r'controller\.speed = 8\.0 is out of range: '
                       r'allowed \[0, 1\] m/s .*the file takes m/s \(8 cm/s = 0\.08\)'):
        SwarmConfig().replace(controller={'speed': 8})
    with pytest.raises(ParameterError, match=r'8 cm/s = 0\.08'):
        SwarmConfig().replace(study={'speeds': [4, 8]})


@pytest.mark.parametrize('text, where', [
    ('population: 3\nspeed: 0.08\n', 'episode.population, controller.speed?'),
    ('episode: {population: 3}\n', 'found episode at the top'),
    ('/**:\n  ros__parameters:\n    population: 3\n', 'population not in a section '
                                                      '(episode.population?)'),
    ('/**:\n  population: 3\n', "'/**' must hold exactly 'ros__parameters'"),
    ('- 1\n- 2\n', 'found list at the top'),
])
def test_a_parameter_file_of_the_wrong_shape_names_the_file_once_and_shows_the_skeleton(
        tmp_path, text, where):
    path = tmp_path / 'flat.yaml'
    path.write_text(text)
    with pytest.raises(ParameterError) as error:
        load_config(path)
    message = str(error.value)
    assert message.startswith(f'{path}: ') and message.count('flat.yaml') == 1, message
    assert where in message
    assert 'skeleton:\n  /**:\n    ros__parameters:\n      episode: {population: 30' in message


@pytest.mark.parametrize('population, side', [(2000, 2.85), (700, 2.85), (60, 0.5)])
def test_does_not_fit_says_how_many_fit_and_how_big_an_arena_holds_them(population, side):
    with pytest.raises(PlacementError) as error:
        place_robots(population, side, RADIUS, placement_rng(1))
    message = str(error.value)
    assert 'does not fit' in message and 'world.arena_side' in message
    found = re.search(r'smaller population \(at most (\d+) fit\) or a bigger '
                      r'world\.arena_side \(at least ([\d.]+) m for', message)
    assert found, message
    fit, bigger = int(found[1]), float(found[2])
    # the advice is right on both counts: that many pass the coverage check, one more not,
    # and the suggested side holds the population
    coverage = math.pi * RADIUS ** 2 / side ** 2
    assert fit * coverage <= MAX_COVERAGE < (fit + 1) * coverage
    assert population * math.pi * RADIUS ** 2 / bigger ** 2 <= MAX_COVERAGE
    assert place_robots(population, bigger, RADIUS, placement_rng(1)).shape == (population, 3)


def test_launch_takes_the_speed_in_cm_per_s_like_run_and_an_old_option_name_still_works(
        capsys):
    from swarm_supervisor.cli.command import build_parser
    from swarm_supervisor.cli.launch import build_parser as launch_parser
    with pytest.raises(SystemExit):
        launch_parser().parse_args(['--speed', '0.08'])
    assert '0.08 cm/s looks like m/s: give cm/s, e.g. --speed 8' in capsys.readouterr().err
    assert launch_parser().parse_args(['--speed', '300']).speed == 300.0  # the schema's to say
    args = build_parser('run').parse_args(['run', '--port', '0', '--out', 'x'])
    assert args.live_port == 0
    assert 'warning: --port is deprecated and will be removed: use --live-port' in \
        capsys.readouterr().err
    assert build_parser('replay').parse_args(['replay', 'bag', '--rate', '4']).pace == 4.0
