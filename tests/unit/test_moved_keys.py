"""The simulator's sensor model left the ``mona`` section for ``sensing``: the old keys still
work for one release, each with a DeprecatedKeyWarning naming its new key, in every place a
key is read (a parameter file, ``replace``, a study factor, a calibration range, an old
announcement); given both ways, a key is refused."""

from __future__ import annotations

import dataclasses

import pytest
import yaml

from mona_controller.mappings import from_mapping
from mona_controller.mona import SENSOR_MODEL, MonaParams
from mona_controller.schema import DeprecatedKeyWarning, ParameterError
from swarm_metrics.bags.analysis import EpisodeSetup
from swarm_supervisor.calibration.design import load_design
from swarm_supervisor.config import SwarmConfig, load_config
from swarm_world.sensing.params import SensingParams


def parameter_file(tmp_path, sections: dict) -> str:
    path = tmp_path / 'old.yaml'
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': sections}}))
    return str(path)


def test_the_sensor_model_is_its_own_section():
    assert SENSOR_MODEL == tuple(field.name for field in dataclasses.fields(SensingParams))
    assert not set(SENSOR_MODEL) & {field.name for field in dataclasses.fields(MonaParams)}


def test_an_old_parameter_file_works_with_one_warning_per_key(tmp_path):
    path = parameter_file(tmp_path, {'mona': {'ir_range': 0.02, 'ground_noise': 5.0,
                                              'command_latency': 2}})
    with pytest.warns(DeprecatedKeyWarning) as caught:
        config = load_config(path)
    assert sorted(str(w.message) for w in caught) == [
        'mona.command_latency is deprecated: use sensing.command_latency',
        'mona.ground_noise is deprecated: use sensing.ground_noise']
    assert (config.mona.ir_range, config.sensing.ground_noise,
            config.sensing.command_latency) == (0.02, 5.0, 2)
    assert config == SwarmConfig().replace(mona={'ir_range': 0.02},
                                           sensing={'ground_noise': 5.0, 'command_latency': 2})


def test_a_key_given_both_ways_is_refused(tmp_path):
    path = parameter_file(tmp_path, {'mona': {'ground_noise': 5.0},
                                     'sensing': {'ground_noise': 4.0}})
    with pytest.raises(ParameterError, match='mona.ground_noise and sensing.ground_noise are '
                                             'both given: give sensing.ground_noise only'):
        load_config(path)


def test_replace_a_study_factor_and_a_calibration_range_take_the_old_key(tmp_path):
    with pytest.warns(DeprecatedKeyWarning, match='use sensing.wheel_noise'):
        assert SwarmConfig().replace(mona={'wheel_noise': 0.1}).sensing.wheel_noise == 0.1
    with pytest.warns(DeprecatedKeyWarning, match='use sensing.ir_miss'):
        study = SwarmConfig().replace(study={'factors': {'mona.ir_miss': [0.0, 0.1]}}).study
    assert study.factors == (('sensing.ir_miss', (0.0, 0.1)),)
    path = tmp_path / 'calibration.yaml'
    path.write_text(yaml.safe_dump({'calibrate': {'parameters': {
        'mona.robot_detection': {'choices': ['beam', 'position']}}}}))
    with pytest.warns(DeprecatedKeyWarning, match='use sensing.robot_detection'):
        design = load_design(path)
    assert [r.key for r in design.parameters] == ['sensing.robot_detection']


def test_the_mona_section_alone_names_where_a_key_went():
    with pytest.raises(ParameterError, match='mona.ground_noise moved to sensing.ground_noise'):
        from_mapping(MonaParams, {'ground_noise': 1.0}, 'mona.')


def test_an_announcement_recorded_before_the_move_is_read_at_the_new_keys():
    setup = EpisodeSetup.from_announcement({
        'episode': 0, 'seed': 1, 'population': 1, 'duration': 1.0, 'start_ns': 0,
        'poses': [[1.0, 1.0, 0.0]],
        'parameters': {'mona': {'ir_range': 0.02, 'ground_footprint': 0.03}}})
    assert (setup.mona.ir_range, setup.sensing.ground_footprint) == (0.02, 0.03)
