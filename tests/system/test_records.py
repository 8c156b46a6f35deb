"""Records you can trust on a busy machine: scripts/swarm.sh with its metrics node stopped
(SIGSTOP) at each moment of a run, started late, or never ready. The world waits for what
the record lacks, the run exits 0 and the bag is complete by the verdict ``analyze`` gives
and equal to the embedded run; a run whose record is incomplete exits 1 naming what is
missing, and ``analyze`` refuses that bag for the same reasons."""

from __future__ import annotations

import os
import signal
import time

import pytest

from swarm_metrics.bags.analysis import recompute
from swarm_metrics.bags.checks import failed_checks
from swarm_metrics.bags.completeness import check_bag_file
from swarm_metrics.bags.reader import read_episode_bag
from swarm_supervisor.config import load_config
from swarm_supervisor.engine.runner import run_episode

from swarmrun import CONFIG, SwarmRun

pytestmark = pytest.mark.ros

POPULATION, DURATION = 3, 6.0
#: Wall seconds the metrics node is kept stopped (the world could run the episode in it).
STALL = 5.0
#: The moments: what the metrics node's or the world's log says just before the SIGSTOP.
MOMENTS = {
    'late': None,  # before it has even imported rclpy: as if started late
    'startup': ('metrics', 'recording episodes into'),  # up, before any announcement
    'recording': ('metrics', '): recording '),  # the episode's bag just opened
    'announcement': ('world', 'waiting for the controllers'),  # as the episode is announced
    'middle': ('world', 'step 0 done'),  # the world must hold for it
    'end': None,  # once the episode steps, until the world has finished: across the end
}
#: The moments whose stall may begin after the start is recorded: the world holds within
#: the episode, 1 s of sim time behind its recorder (it must in the middle).
HELD_WITHIN = ('recording', 'announcement', 'middle')
#: Stopped for longer than Fast DDS's participant lease (20 s), a node is dropped by the
#: others' writers, and what they sent meanwhile is lost to it: the stalls stay shorter.


def embedded_rows(seed: int, duration: float = DURATION) -> list[dict]:
    config = load_config(CONFIG).replace(
        episode={'population': POPULATION, 'duration': duration, 'seed': seed})
    return run_episode(config).metrics


def the_bag(run: SwarmRun):
    return run.out / 'episode_0' / 'bag'


def start(swarm, seed: int, *args: str, duration: float = DURATION) -> SwarmRun:
    return swarm('--population', str(POPULATION), '--controllers-per-process', '3',
                 '--duration', str(duration), '--seed', str(seed), *args)


def stop_metrics_node(run: SwarmRun, moment: str) -> int:
    """SIGSTOP the metrics node at ``moment``; returns its pid."""
    if moment == 'end':
        # Once the episode steps: with recorder_lag (10 s) longer than the episode (6 s) the
        # world runs to its end while the node is stopped. (Waiting for the last 2 s of a
        # status missed the window on a busy machine: the episode ended between two statuses.)
        run.wait_for(lambda: 'step 0 done' in run.log('world'), 'the first step')
    elif MOMENTS[moment] is not None:
        node, text = MOMENTS[moment]
        run.wait_for(lambda: text in run.log(node), f'{text!r} in the {node} log')
    else:
        run.wait_for(lambda: 'metrics' in run.nodes(), 'the metrics process', timeout=60)
    pid = run.nodes()['metrics']
    os.kill(pid, signal.SIGSTOP)
    return pid


@pytest.mark.parametrize('moment', list(MOMENTS))
def test_a_stalled_metrics_node_is_waited_for_and_its_bag_is_complete(swarm, moment):
    seed = 20 + list(MOMENTS).index(moment)
    # A lag of one sample period (1 s) instead of 10 s where the world must hold within the
    # episode: in the middle, and where the node may have recorded the start before the
    # SIGSTOP lands (a log line is read some time after it is written).
    lag = ['-p', 'recorder_lag:=1.0'] if moment in HELD_WITHIN else []
    run = start(swarm, seed, *lag)
    pid = stop_metrics_node(run, moment)
    if moment == 'end':  # the world finishes the episode while its recorder is stopped
        run.wait_for(lambda: 'episode 0 finished' in run.log('world'), 'the end')
        time.sleep(1.0)
    else:
        time.sleep(STALL)
    assert ('episode 0 finished' in run.log('world')) == (moment == 'end')
    os.kill(pid, signal.SIGCONT)
    status = run.wait()

    assert status == 0, run.stderr + run.log('world')[-2000:] + run.log('metrics')[-2000:]
    assert 'complete: the world finished the episode' in run.log('metrics')
    assert check_bag_file(the_bag(run)) == []  # analyze's verdict, sources at t = 0 included
    assert recompute(read_episode_bag(the_bag(run))).rows == embedded_rows(seed)
    # Step 0 waited until the start was in the bag; in the middle the world held back
    # instead of running away from its recorder.
    world = run.log('world')
    assert 'step 0: waiting for recorder(s) metrics to record the start' in world
    caught_up = 'waiting for recorder(s) metrics to catch up' in world
    assert caught_up if moment == 'middle' else (caught_up <= (moment in HELD_WITHIN))


def test_busy_machine_records_are_complete(swarm, busy_cores):
    run = start(swarm, 30)
    status = run.wait()
    assert status == 0, run.stderr + run.log('world')[-2000:]
    assert check_bag_file(the_bag(run)) == []
    assert recompute(read_episode_bag(the_bag(run))).rows == embedded_rows(30)


def test_a_recorder_that_never_confirms_fails_the_episode_naming_it(swarm):
    run = start(swarm, 31, '--start-timeout', '5')
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


def test_an_incomplete_record_exits_1_naming_what_analyze_finds_missing(swarm):
    """Told not to wait for its recorder while running (recorder_lag 0), the world runs a
    50 s episode (1563 poses) while the metrics node is stopped: its subscriptions keep 1000
    messages, so the first seconds are lost. The run must exit 1 naming what the bag lacks,
    the very findings analyze gives."""
    duration = 50.0
    run = start(swarm, 32, '-p', 'recorder_lag:=0.0', duration=duration)
    pid = stop_metrics_node(run, 'middle')
    run.wait_for(lambda: 'episode 0 finished' in run.log('world'), 'the end')
    os.kill(pid, signal.SIGCONT)
    status = run.wait()

    findings = check_bag_file(the_bag(run))
    print(f'\nstalled without flow control: exit {status}, '
          f'the bag fails {failed_checks(findings)}')
    assert status == 1 and 'samples' in failed_checks(findings), run.stderr
    assert 'incomplete record from metrics' in run.log('supervisor')
    for finding in findings:  # the launcher names each, as the recorder judged them
        assert str(finding) in run.stderr
