"""The shipped profiles of ros_ws/config/profiles/ and how report.md names a study's Monas."""

from __future__ import annotations

import pytest

from swarm_supervisor.analysis import profile
from swarm_supervisor.config import load_config


def _record(config):
    return {'parameters': config.to_dict()}


def test_every_shipped_profile_loads_and_idealised_is_the_default():
    names = sorted(path.stem for path in profile.PROFILES_DIR.glob('*.yaml'))
    assert names == ['idealised', 'real_link', 'webots']
    assert load_config(profile.PROFILES_DIR / 'idealised.yaml') == load_config()
    # Each profile sets only the sensing and encounter chain.
    webots = load_config(profile.PROFILES_DIR / 'webots.yaml')
    changed = [key for key, value in profile.chain_of(webots.to_dict()).items()
               if value != profile.chain_of({})[key]]
    assert 'sensing.ground_transfer' in changed and 'world.cleaning' in changed
    assert webots.study == load_config().study and webots.episode == load_config().episode
    real = load_config(profile.PROFILES_DIR / 'real_link.yaml')
    assert (real.mona.ir_range, real.sensing.command_latency) == (0.02, 3)
    assert real.replace(mona={'ir_range': 0.03}, sensing={'command_latency': 0}) == load_config()


def test_the_real_link_profile_is_named_by_its_latency_too():
    real = load_config(profile.PROFILES_DIR / 'real_link.yaml')
    assert '`real_link` profile' in profile.describe([_record(real)])
    line = profile.describe([_record(real.replace(sensing={'command_latency': 0}))])
    assert 'a profile of its own' in line and '`mona.ir_range` = 0.02' in line


def test_describe_names_the_profile_and_what_departs_from_the_default():
    line = profile.describe([_record(load_config())])
    assert '`idealised` profile' in line and 'at its idealised default' in line
    line = profile.describe([_record(load_config(profile.PROFILES_DIR / 'webots.yaml'))])
    assert '`webots` profile' in line and '`sensing.ground_transfer` = webots' in line


def test_a_changed_link_is_a_profile_of_its_own():
    line = profile.describe([_record(load_config().replace(mona={'ir_range': 0.02}))])
    assert 'a profile of its own' in line and '`mona.ir_range` = 0.02' in line


@pytest.mark.parametrize('missing', ['mona', 'world'])
def test_an_old_record_without_a_link_counts_it_at_its_default(missing):
    parameters = load_config().to_dict()
    del parameters[missing]
    assert profile.chain_of(parameters) == profile.chain_of({})
