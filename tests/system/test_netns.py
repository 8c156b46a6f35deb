"""The node system across two "hosts": two network namespaces joined by a veth pair,
the core (world, metrics, supervisor) in one, the five controllers in the other, discovering
each other by unicast over the veth with the profile ``--peers`` writes. A 20 s lockstep
episode must give the single-host run's record: test_system.py holds the single-host bag to the
embedded runner bit for bit, so this test holds the two-host bag to the embedded runner too
(the same comparisons), rather than spending another minute on a second ROS run.

Needs root (``ip netns add``); skips, saying why, where namespaces cannot be made.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Iterator

import numpy as np
import pytest

from swarm_metrics.bags.analysis import recompute
from swarm_metrics.bags.reader import read_episode_bag
from swarm_supervisor.config import load_config
from swarm_supervisor.engine.runner import run_episode

from swarmrun import CONFIG, SwarmRun, group_alive

pytestmark = pytest.mark.ros

POPULATION, DURATION, SEED = 5, 20.0, 7
METRICS = ('mean_cue', 'mean_cue_fraction', 'ratio_near_source', 'coherency')
#: Any domain: each namespace has its own ports, so no other run on the machine can collide.
DOMAIN = 42
#: The two hosts' addresses on the veth pair (a private range, inside the namespaces only).
CORE_IP, CONTROLLERS_IP = '10.252.0.1', '10.252.0.2'


def ip(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(['ip', *args], capture_output=True, text=True, timeout=30)


@pytest.fixture
def hosts() -> Iterator[tuple[str, str]]:
    """Two network namespaces (core, controllers) joined by a veth pair, removed afterwards."""
    if shutil.which('ip') is None:
        pytest.skip('no ip command (iproute2) to make network namespaces: make system-tools')
    if os.geteuid() != 0:
        pytest.skip('network namespaces need root (ip netns add)')
    tag = os.getpid()
    core, controllers = f'mona{tag}core', f'mona{tag}ctl'
    made: list[str] = []
    try:
        for name in (core, controllers):
            result = ip('netns', 'add', name)
            if result.returncode != 0:
                pytest.skip(f'cannot create a network namespace: {result.stderr.strip()}')
            made.append(name)
        ends = (f'mv{tag}a'[-15:], f'mv{tag}b'[-15:])  # interface names: at most 15 chars
        steps = [('link', 'add', ends[0], 'type', 'veth', 'peer', 'name', ends[1]),
                 ('link', 'set', ends[0], 'netns', core),
                 ('link', 'set', ends[1], 'netns', controllers)]
        for name, end, address in ((core, ends[0], CORE_IP),
                                   (controllers, ends[1], CONTROLLERS_IP)):
            steps += [('-n', name, 'addr', 'add', f'{address}/24', 'dev', end),
                      ('-n', name, 'link', 'set', end, 'up'),
                      ('-n', name, 'link', 'set', 'lo', 'up')]
        for step in steps:
            result = ip(*step)
            if result.returncode != 0:
                pytest.skip(f'cannot join the namespaces (ip {" ".join(step)}): '
                            f'{result.stderr.strip()}')
        yield core, controllers
    finally:
        for name in made:  # removing a namespace removes its end of the veth pair, and so both
            ip('netns', 'del', name)


@pytest.mark.slow
def test_core_and_controllers_in_two_namespaces_give_the_single_host_record(hosts, tmp_path):
    core_ns, controllers_ns = hosts
    common = ['--domain', str(DOMAIN), '--peers', f'{CORE_IP},{CONTROLLERS_IP}',
              '--population', str(POPULATION), '--duration', str(DURATION),
              '--seed', str(SEED), '--mode', 'lockstep']
    runs = [SwarmRun(tmp_path / 'core', ['--role', 'core', *common],
                     prefix=['ip', 'netns', 'exec', core_ns]),
            SwarmRun(tmp_path / 'controllers',
                     ['--role', 'controllers', '--robots', f'0-{POPULATION - 1}', *common],
                     prefix=['ip', 'netns', 'exec', controllers_ns])]
    try:
        statuses = [runs[0].wait()]
        # The controllers end on the supervisor's shutdown announcement; if the core failed
        # they would wait for it until their --timeout, so they get a bounded wait.
        try:
            statuses.append(runs[1].wait(timeout=90))
        except subprocess.TimeoutExpired:
            statuses.append(None)
    finally:
        for run in runs:
            run.stop()
    core, controllers = runs
    assert statuses == [0, 0], f'{core.stderr}\n{controllers.stderr}'
    assert set(core.nodes()) == {'world', 'metrics', 'supervisor'}
    assert set(controllers.nodes()) == {f'controller_{i}' for i in range(POPULATION)}
    assert not [pgid for run in runs for pgid in run.nodes().values() if group_alive(pgid)]
    for run, here in ((core, CORE_IP), (controllers, CONTROLLERS_IP)):
        assert f'(here {here})' in run.stderr
        assert f'<address>{here}</address>' in (run.out / 'fastdds_peers.xml').read_text()

    config = load_config(CONFIG).replace(
        episode={'population': POPULATION, 'duration': DURATION, 'seed': SEED})
    embedded = run_episode(config)
    final = np.load(core.out / 'episode_0' / 'world_final.npz')
    assert not final['misses'].any() and int(final['dropped']) == 0
    assert int(final['steps']) == embedded.steps
    np.testing.assert_array_equal(final['poses'], embedded.final_poses)
    np.testing.assert_array_equal(final['cue'], embedded.final_cue.astype(np.float32))
    assert not np.allclose(embedded.final_poses, embedded.initial_poses)  # they did move
    bag = read_episode_bag(core.out / 'episode_0' / 'bag')
    recomputed = recompute(bag).rows
    assert len(recomputed) == len(embedded.metrics)
    for name in METRICS:
        _, online = bag.metric(name)
        expected = [row[name] for row in embedded.metrics]
        np.testing.assert_allclose(online, expected, rtol=1e-12, atol=1e-12, err_msg=name)
        np.testing.assert_allclose([row[name] for row in recomputed], expected, rtol=1e-12,
                                   atol=1e-12, err_msg=name)

