"""Keys of three levels (``controller.beeclust.alpha``) wherever a key is named, and the keys
from before the controller kinds had sections, which work for one release with a
DeprecationWarning naming the new key."""

from __future__ import annotations

import pickle
import subprocess
import sys
from pathlib import Path

import pytest

from mona_controller.controllers import ControllerParams
from mona_controller.keys import leaf
from mona_controller.mappings import from_mapping
from mona_controller.schema import DeprecatedKeyWarning, ParameterError
from swarm_supervisor.config import SwarmConfig, current_keys, load_config
from swarm_supervisor.study import specs

OLD = '/**:\n  ros__parameters:\n    controller:\n      alpha: 3.0\n      turn_at: full\n' \
      '      network_hidden: 4\n'


def test_an_old_file_still_loads_with_a_warning_naming_each_new_key(tmp_path):
    path = tmp_path / 'old.yaml'
    path.write_text(OLD)
    with pytest.warns(DeprecatedKeyWarning) as warned:
        config = load_config(path)
    assert {str(w.message) for w in warned} == {
        'controller.alpha is deprecated: use controller.beeclust.alpha',
        'controller.turn_at is deprecated: use controller.beeclust.turn_at',
        'controller.network_hidden is deprecated: use controller.network.hidden'}
    assert issubclass(DeprecatedKeyWarning, DeprecationWarning)
    assert (config.controller.beeclust.alpha, config.controller.beeclust.turn_at,
            config.controller.network.hidden) == (3.0, 'full', 4)
    assert config == SwarmConfig().with_values({'controller.beeclust.alpha': 3.0,
                                                'controller.beeclust.turn_at': 'full',
                                                'controller.network.hidden': 4})


def test_an_old_key_beside_its_new_one_is_refused():
    with pytest.raises(ParameterError, match='controller.alpha and controller.beeclust.alpha '
                                             'are both given: give controller.beeclust.alpha '
                                             'only'), pytest.warns(DeprecatedKeyWarning):
        from_mapping(ControllerParams, {'alpha': 3.0, 'beeclust': {'alpha': 3.0}},
                     'controller.')


def test_old_keys_in_code_options_and_factors_still_work():
    with pytest.warns(DeprecatedKeyWarning, match='use controller.beeclust.wait_max'):
        config = SwarmConfig().replace(controller={'wait_max': 5.0, 'speed': 0.04})
    assert (config.controller.beeclust.wait_max, config.controller.speed) == (5.0, 0.04)
    with pytest.warns(DeprecatedKeyWarning, match='use controller.network.seed'):
        seeded = SwarmConfig().with_values({'controller.network_seed': 9})
    assert seeded.controller.network.seed == 9
    with pytest.warns(DeprecatedKeyWarning, match='use controller.beeclust.avoid'):
        factors = SwarmConfig().replace(study={'factors': {'controller.avoid': ['random-turn']}})
    assert factors.study.factors == (('controller.beeclust.avoid', ('random-turn',)),)


def test_three_level_keys_are_factors_levels_and_values():
    config = SwarmConfig().replace(study={
        'factors': {'controller.beeclust.alpha': [2, 10], 'controller.kind': ['beeclust',
                                                                               'network']},
        'populations': [5], 'speeds': [0.04], 'seeds': [1]})
    assert config.study.factors == (('controller.beeclust.alpha', (2.0, 10.0)),
                                    ('controller.kind', ('beeclust', 'network')))
    episodes = specs.design(config)
    assert len(episodes) == 4
    last = specs.episode_config(config, episodes[-1])
    assert (last.controller.beeclust.alpha, last.controller.kind, last.controller.speed) == (
        10.0, 'network', 0.04)
    assert specs.parameter_value(last, 'controller.beeclust.alpha') == 10.0
    with pytest.raises(ParameterError, match='controller.speed is set by the design; use '
                                             'study.speeds'):
        SwarmConfig().replace(study={'factors': {'controller.speed': [0.04]}})
    with pytest.raises(ParameterError, match='no parameter controller.beeclust.gain'):
        SwarmConfig().replace(study={'factors': {'controller.beeclust.gain': [1]}})
    with pytest.raises(ParameterError, match=r'controller.beeclust.alpha = 0.0 is out of range'):
        SwarmConfig().replace(study={'factors': {'controller.beeclust.alpha': [0.0]}})


def test_a_key_is_found_below_any_section_and_a_missing_one_is_named():
    assert leaf(SwarmConfig(), 'controller.network.max_speed')[:2] == (
        'controller.network.max_speed', 0.0)
    for missing in ('controller.beeclust', 'controller.beeclust.alpha.x', 'controller.kinds',
                    'nothing.at.all'):
        with pytest.raises(ParameterError, match=f'no parameter {missing}'):
            leaf(SwarmConfig(), missing)


def test_a_record_of_an_older_version_is_read_under_the_new_keys():
    record = {'controller': {'speed': 0.04, 'alpha': 7.0, 'network_hidden': 3}}
    assert current_keys(record)['controller'] == {'speed': 0.04, 'beeclust': {'alpha': 7.0},
                                                  'network': {'hidden': 3}}


def test_the_section_pickles_and_copies_to_the_same_parameters():
    params = SwarmConfig().with_values({'controller.beeclust.alpha': 4.0}).controller
    assert pickle.loads(pickle.dumps(params)) == params
    assert hash(pickle.loads(pickle.dumps(params))) == hash(params)


def test_the_command_line_shows_a_renamed_key_once_as_one_line(tmp_path):
    path = tmp_path / 'old.yaml'
    path.write_text(OLD + '    episode: {population: 2, duration: 1.0}\n')
    done = subprocess.run([str(Path(sys.executable).with_name('mona-swarm')), 'run',
                           '--config', str(path), '--out', str(tmp_path / 'run')],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    lines = [line for line in done.stderr.splitlines() if 'deprecated' in line]
    assert lines == ['mona-swarm: warning: controller.alpha is deprecated: use '
                     'controller.beeclust.alpha',
                     'mona-swarm: warning: controller.turn_at is deprecated: use '
                     'controller.beeclust.turn_at',
                     'mona-swarm: warning: controller.network_hidden is deprecated: use '
                     'controller.network.hidden']
