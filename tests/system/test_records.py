"""Records you can trust on a busy machine: the metrics node stalled (SIGSTOP) at
each moment that used to lose the start of an episode, started late, or never ready. The
episode waits for its recorder, and the bag equals the embedded run; a run whose record is
incomplete never exits 0."""

from __future__ import annotations

import os
import signal
import time

import pytest

from swarm_metrics.bags.analysis import recompute
from swarm_metrics.bags.reader import read_episode_bag
from swarm_supervisor.config import load_config
from swarm_supervisor.engine.runner import run_episode

from swarmrun import CONFIG, SwarmRun

pytestmark = pytest.mark.ros

POPULATION, DURATION = 5, 20.0
#: How long the metrics node is kept stopped: longer than the world needs for the episode.
STALL = 15.0


def embedded_rows(seed: int) -> list[dict]:
    config = load_config(CONFIG).replace(
        episode={'population': POPULATION, 'duration': DURATION, 'seed': seed})
    return run_episode(config).metrics


def bag_rows(run: SwarmRun) -> list[dict]:
    return recompute(read_episode_bag(run.out / 'episode_0' / 'bag')).rows


def metrics_pid(run: SwarmRun) -> int:
    run.wait_for(lambda: 'metrics' in run.nodes(), 'the metrics process', timeout=60)
    return run.nodes()['metrics']


def stop_metrics_node(run: SwarmRun, moment: str) -> int:
    """SIGSTOP the metrics node at ``moment``; returns its pid."""
    if moment == 'late':  # before it has even imported rclpy: as if started late
        pid = metrics_pid(run)
    elif moment == 'startup':  # just after start-up, as a swapped-out process would
        run.wait_for(lambda: 'recording episodes into' in run.log('metrics'), 'start-up')
        time.sleep(0.7)
        pid = run.nodes()['metrics']
    elif moment == 'announcement':  # while the episode is being announced
        run.wait_for(lambda: 'waiting for the controllers' in run.log('world'),
                     'the announcement')
        pid = run.nodes()['metrics']
    else:  # 'running': in the middle of the episode
        run.wait_running(after=1.0)
        pid = run.nodes()['metrics']
    os.kill(pid, signal.SIGSTOP)
    return pid


# make test stalls it once the episode runs; the other moments are the extended tier.
@pytest.mark.parametrize('moment', [pytest.param(m, marks=pytest.mark.extended)
                                    for m in ('late', 'startup', 'announcement')] + ['running'])
def test_stalled_metrics_node_is_waited_for_and_its_bag_is_complete(swarm, moment):
    seed = 20 + ['late', 'startup', 'announcement', 'running'].index(moment)
    # While running, the world must catch up with the stopped recorder even on a machine so
    # loaded that it steps 0.5 s of sim time per wall second: a 2 s lag instead of 10 s.
    lag = ['-p', 'recorder_lag:=2.0'] if moment == 'running' else []
    run = swarm('--population', str(POPULATION), '--duration', str(DURATION),
                '--seed', str(seed), *lag)
    pid = stop_metrics_node(run, moment)
    time.sleep(STALL)
    os.kill(pid, signal.SIGCONT)
    status = run.wait()

    assert status == 0, run.stderr + run.log('world')[-2000:] + run.log('metrics')[-2000:]
    assert 'complete: the world finished the episode' in run.log('metrics')
    assert bag_rows(run) == embedded_rows(seed)  # every sample from t = 0, exactly
    if moment == 'running':  # the world held back instead of running away from its recorder
        assert 'waiting for recorder(s) metrics to catch up' in run.log('world')


def test_busy_machine_records_are_complete(swarm, busy_cores):
    run = swarm('--population', str(POPULATION), '--duration', str(DURATION), '--seed', '30')
    status = run.wait()
    assert status == 0, run.stderr + run.log('world')[-2000:]
    assert bag_rows(run) == embedded_rows(30)


def test_a_recorder_that_never_confirms_fails_the_episode_naming_it(swarm):
    run = swarm('--population', str(POPULATION), '--duration', str(DURATION), '--seed', '31',
                '--start-timeout', '5')
    pid = stop_metrics_node(run, 'late')
    try:
        run.wait_for(lambda: 'the recorder(s) metrics did not confirm' in run.log('world'),
                     'the world to give up on its recorder', timeout=120)
    finally:
        os.kill(pid, signal.SIGCONT)  # so that it can be stopped politely
    status = run.wait()
    assert status == 1, run.stderr
    # The script names the failed node and why: the recorder that did not confirm.
    assert 'FAILED supervisor' in run.stderr or 'FAILED world' in run.stderr
    assert 'the recorder(s) metrics did not confirm' in run.stderr
    assert not (run.out / 'episode_0' / 'world_final.npz').exists()  # it never ran


def test_an_incomplete_record_never_exits_zero(swarm):
    """Without the world waiting for its recorder (recorder_lag 0), a stalled metrics node
    loses what its bounded queues could not hold; the run must then say so."""
    seed = 32
    run = swarm('--population', str(POPULATION), '--duration', '60', '--seed', str(seed),
                '-p', 'recorder_lag:=0.0')
    pid = stop_metrics_node(run, 'running')
    time.sleep(25.0)
    os.kill(pid, signal.SIGCONT)
    status = run.wait()

    config = load_config(CONFIG).replace(
        episode={'population': POPULATION, 'duration': 60.0, 'seed': seed})
    complete = bag_rows(run) == run_episode(config).metrics
    print(f'\nstalled without flow control: exit {status}, bag complete: {complete}')
    assert (status == 0) == complete, run.stderr + run.log('metrics')[-2000:]
    if not complete:
        assert 'incomplete record from metrics' in run.log('supervisor')
