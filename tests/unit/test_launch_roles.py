"""The launcher's roles and LAN profile without ROS: what ``--role`` starts, which
robots ``--robots`` gives a host, the split runs it refuses, and the ``--peers`` profile."""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from swarm_supervisor.cli import launch as launch_cli
from swarm_supervisor.cli import main
from swarm_supervisor.system import launcher
from swarm_supervisor.system.node_commands import controller_groups, node_commands
from swarm_supervisor.system.processes import local_address, peers_profile

EXECUTABLES = {kind: f'/bin/{kind}' for kind in launcher.EXECUTABLES}
NS = '{http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles}'


def commands(*argv: str, population: int = 5) -> dict[str, list[str]]:
    parsed = launch_cli.build_parser().parse_args(list(argv))
    return node_commands(parsed, population, Path('/tmp/out'), EXECUTABLES)


def test_each_role_starts_its_part():
    assert list(commands()) == ['world', 'metrics', *(f'controller_{i}' for i in range(5)),
                                'supervisor']
    assert list(commands('--role', 'core')) == ['world', 'metrics', 'supervisor']
    assert list(commands('--role', 'supervision')) == ['metrics', 'supervisor']
    assert list(commands('--role', 'controllers', '--robots', '1-3')) == \
        ['controller_1', 'controller_2', 'controller_3']
    hosted = commands('--role', 'controllers', '--robots', '0-24', '--controllers-per-process',
                      '10', population=50)
    assert list(hosted) == ['controller_0-9', 'controller_10-19', 'controller_20-24']
    assert hosted['controller_20-24'][1:3] == ['--robots', '20-24']


def test_controller_groups_of_given_robots():
    assert controller_groups(10, 2, [0, 1, 2, 7, 8]) == ['0-1', '2,7', '8']
    assert controller_groups(10, 3) == ['0-2', '3-5', '6-8', '9']


@pytest.mark.parametrize('spec, ids', [('3', [3]), ('0-4', [0, 1, 2, 3, 4]),
                                       ('0,2,5-6', [0, 2, 5, 6])])
def test_robots_spec(spec, ids):
    assert launch_cli.parse_robots(spec) == ids


@pytest.mark.parametrize('argv, message', [
    (['--robots', 'a-b'], '--robots'),
    (['--robots', '4-2'], '--robots'),
    (['--robots', '1,1'], '--robots'),
    (['--role', 'world'], '--role'),
    (['--peers', '10.0.0.300'], '--peers'),
    (['--domain', '233'], '--domain'),
])
def test_a_bad_role_option_is_named(argv, message, capsys):
    with pytest.raises(SystemExit) as stopped:
        main(['launch', *argv])
    assert stopped.value.code == 2
    error = capsys.readouterr().err.splitlines()[-1]
    assert error.startswith('mona-swarm launch: error: ') and message in error


@pytest.mark.parametrize('argv', [
    ['--role', 'core'],  # no domain: the hosts would not meet
    ['--role', 'controllers', '--domain', '3'],  # which robots?
    ['--role', 'controllers', '--domain', '3', '--robots', '3-7', '--population', '5'],
    ['--robots', '0-4'],  # robots without the controllers role
    ['--peers', '192.0.2.1'],  # TEST-NET-1: not an address of this host
])
def test_a_split_run_it_cannot_make_work_exits_2_before_starting(argv, tmp_path, capsys,
                                                                  monkeypatch):
    monkeypatch.delenv('SWARM_DOMAIN_ID', raising=False)
    assert main(['launch', *argv, '--out', str(tmp_path / 'out')]) == 2
    assert 'mona-swarm launch: ' in capsys.readouterr().err
    assert not (tmp_path / 'out' / 'processes.tsv').exists()


def test_local_address_is_the_one_this_host_can_bind():
    assert local_address(['192.0.2.1', '127.0.0.1']) == '127.0.0.1'
    assert local_address(['192.0.2.1']) is None


def test_peers_profile_is_unicast_on_this_address_to_every_peer():
    root = ET.fromstring(peers_profile('10.1.0.2', ['10.1.0.1', '10.1.0.2', '10.1.0.3']))
    participant = root.find(f'{NS}participant')
    assert participant.get('is_default_profile') == 'true'
    builtin = participant.find(f'{NS}rtps/{NS}builtin')
    peers = [a.text for a in builtin.find(f'{NS}initialPeersList').iter(f'{NS}address')]
    assert peers == ['10.1.0.1', '10.1.0.2', '10.1.0.3']
    own = [a.text for a in builtin.find(f'{NS}metatrafficUnicastLocatorList').iter(
        f'{NS}address')]
    assert own == ['10.1.0.2']
    assert root.find(f'{NS}transport_descriptors/{NS}transport_descriptor/'
                     f'{NS}interfaceWhiteList/{NS}address').text == '10.1.0.2'
    assert participant.find(f'{NS}rtps/{NS}builtin/{NS}metatrafficMulticastLocatorList') is None
    assert os.path.basename(launcher.PEERS_PROFILE) == 'fastdds_peers.xml'
