"""The one parameter schema: YAML loading, unknown keys, ranges, messages that name the key."""

import pytest

from mona_controller.controllers import ControllerParams, SwarmController
from mona_controller.mappings import flat_fields, from_mapping
from mona_controller.schema import ParameterError
from swarm_supervisor.config import DEFAULT_CONFIG, SwarmConfig, load_config, write_ros_yaml


def test_shipped_yaml_equals_the_defaults():
    assert DEFAULT_CONFIG.exists()
    assert load_config() == SwarmConfig()


def test_round_trip_through_yaml(tmp_path):
    config = SwarmConfig().replace(episode={'population': 12, 'seed': 99},
                                   world={'cleaning': 'literal'})
    write_ros_yaml(config, tmp_path / 'p.yaml')
    assert load_config(tmp_path / 'p.yaml') == config


@pytest.mark.parametrize('section, values, fragment', [
    ('episode', {'population': -3},
     'episode.population = -3 is out of range: allowed [0, 100000]'),
    ('episode', {'population': 2.5}, 'episode.population = 2.5: expected a whole number'),
    ('controller', {'speed': -0.01}, 'controller.speed = -0.01 is out of range'),
    ('controller', {'beeclust': {'alpha': 'two'}}, 'controller.beeclust.alpha'),
    ('world', {'cleaning': 'scrub'}, "world.cleaning = 'scrub' is not allowed"),
    ('controller', {'beeclust': {'turn_min': 3.0, 'turn_max': 2.0}},
     'controller.beeclust.turn_min'),
    ('controller', {'network': {'hidden': 0}}, 'controller.network.hidden = 0 is out of range'),
    ('controller', {'beeclust': 2.0}, 'controller.beeclust must be a section'),
    ('mona', {'ir_count': True}, 'mona.ir_count'),
])
def test_bad_values_name_the_key_and_range(section, values, fragment):
    with pytest.raises(ParameterError, match=None) as error:
        SwarmConfig().replace(**{section: values})
    assert fragment in str(error.value)


def test_unknown_key_is_rejected_with_the_known_ones(tmp_path):
    path = tmp_path / 'bad.yaml'
    path.write_text('/**:\n  ros__parameters:\n    controller:\n      beeclust:\n'
                    '        alpah: 3.0\n')
    with pytest.raises(ParameterError) as error:
        load_config(path)
    message = str(error.value)
    assert 'unknown parameter controller.beeclust.alpah' in message and 'alpha' in message


def test_file_that_is_not_a_parameter_file(tmp_path):
    path = tmp_path / 'x.yaml'
    path.write_text('controller: {alpha: 2}\n')
    with pytest.raises(ParameterError, match="'/\\*\\*' section"):
        load_config(path)
    with pytest.raises(ParameterError, match='cannot read'):
        load_config(tmp_path / 'missing.yaml')


def test_speed_beyond_the_wheel_clamp_is_rejected():
    from mona_controller.mona import MonaParams
    with pytest.raises(ParameterError, match=r'controller.speed = 0.2 is out of range'):
        SwarmController(ControllerParams(speed=0.2), MonaParams(), [0])


def test_flat_fields_give_dotted_ros_names():
    names = {name for name, _, _ in flat_fields(SwarmConfig)}
    assert {'episode.population', 'controller.kind', 'controller.speed',
            'controller.beeclust.alpha', 'controller.network.hidden', 'world.arena_side',
            'study.populations'} <= names
    assert from_mapping(ControllerParams, {'beeclust': {'alpha': 3}}).beeclust.alpha == 3.0


def test_parameter_reference_matches_the_schema():
    from pathlib import Path

    from swarm_supervisor.cli.paramdoc import render
    page = Path(__file__).resolve().parents[2] / 'docs' / 'parameters.md'
    assert page.read_text() == render(), (
        'docs/parameters.md is stale: run python -m swarm_supervisor.cli.paramdoc > '
        'docs/parameters.md')
    rows = [line.split(' | ') for line in render().splitlines() if line.startswith('| `')]
    rows = [row for row in rows if len(row) == 6]  # not the renamed keys' table
    by_key = {row[0].strip('| `'): row for row in rows}
    # Each row names its type; text, booleans and choices show what they take, not a range.
    assert all(row[1] in ('integer', 'number', 'boolean', 'text', 'choice', 'mapping')
               or row[1].startswith('list of ') for row in rows)
    assert not any('inf' in row[4] for row in rows)
    assert by_key['sensing.ground_transfer'][4] == '`linear`, `webots`, `table`'
    assert by_key['controller.network.recurrent'][1:5] == ['boolean', 'false', '',
                                                          '`true`, `false`']
    assert '`beeclust`' in by_key['controller.kind'][4]


def test_the_default_file_is_found_installed_and_its_absence_is_an_error(tmp_path, monkeypatch):
    from swarm_supervisor import config as config_module
    monkeypatch.setattr(config_module, 'SOURCE_CONFIG', tmp_path / 'no_source_tree')
    monkeypatch.setattr(config_module.sys, 'prefix', str(tmp_path / 'venv'))
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path / 'colcon_install'))
    with pytest.raises(ParameterError, match='the shipped mona_swarm.yaml is missing'):
        config_module.load_config()
    installed = tmp_path / 'colcon_install' / config_module.INSTALLED_CONFIG / 'mona_swarm.yaml'
    installed.parent.mkdir(parents=True)
    write_ros_yaml(SwarmConfig().replace(episode={'seed': 77}), installed)
    assert config_module.default_config_path() == installed
    assert config_module.load_config().episode.seed == 77
