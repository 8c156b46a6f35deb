"""Faults with real processes and real signals: a controller, the world or the
metrics node is SIGKILLed in the middle of a lockstep episode started by scripts/swarm.sh.
docs/reliability.md lists what the system does in each case; these tests show it."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from swarm_metrics.bags.reader import read_episode_bag
from swarm_metrics.bags.scan import TruncatedBagError

from swarmrun import CONFIG, group_alive

pytestmark = pytest.mark.ros

POPULATION = 5
BIN = Path(sys.executable).parent


def no_node_left(run) -> list[str]:
    return [name for name, pgid in run.nodes().items() if group_alive(pgid)]


def test_killed_controller_is_counted_and_a_restarted_one_rejoins(swarm, processes):
    # A short deadline keeps the test quick: 3 missed steps cost 1.5 s before the robot is
    # absent and no longer waited for.
    # Killed early in a 60 s episode: the replacement needs a few wall seconds to start, and
    # the world runs 1.5 to 6 sim seconds per wall second depending on the machine's load.
    run = swarm('--population', str(POPULATION), '--duration', '60', '--seed', '5',
                '-p', 'lockstep_deadline:=0.5')
    # Past step 0, whose deadline is start_timeout (new DDS matches may hold its first
    # messages back): a controller killed before it answers step 0 costs that long.
    run.wait_for(lambda: 'step 0 done' in run.log('world'), 'step 0')
    time.sleep(0.5)
    killed_at = time.monotonic()
    os.killpg(run.nodes()['controller_2'], signal.SIGKILL)
    run.wait_for(lambda: 'robots [2] missed 3 steps in a row' in run.log('world'),
                 'robot 2 marked absent', timeout=60)
    absent_after = time.monotonic() - killed_at

    again = processes.spawn(
        [str(BIN / 'mona_controller_node'), '--robots', '2', '--ros-args', '--params-file',
         str(CONFIG)], 'controller_2_again', env=run.env())
    run.wait_for(lambda: 'robot 2 is back' in run.log('world'), 'robot 2 back', timeout=120)
    status = run.wait()
    assert again.wait(60) == 0, processes.log('controller_2_again')  # ended on the shutdown

    # The script's verdict names the dead controller; the episode itself finished.
    assert status == 1, run.stderr
    assert 'FAILED controller_2' in run.stderr and 'SIGKILL' in run.stderr
    assert 'FAILED' not in run.stderr.replace('FAILED controller_2', '')
    assert not no_node_left(run)
    final = np.load(run.out / 'episode_0' / 'world_final.npz')
    misses = final['misses']
    # Robot 2 missed until it was absent (3 in a row) and again until it was back; the others
    # miss a round only when the loaded machine stalls the world past the deadline.
    others = misses[[0, 1, 3, 4]]
    assert misses[2] >= 3 and misses[2] > others.max(), misses
    record = json.loads((run.out / 'run.json').read_text())
    assert record['episodes'][0]['misses'] == int(misses.sum())
    assert record['episodes'][0]['steps'] == int(final['steps'])

    # The bag holds it too: the last status counts the misses, and while robot 2 was absent
    # its pose stood still.
    bag = read_episode_bag(run.out / 'episode_0' / 'bag')
    assert bag.status[-1][1]['state'] == 'finished'
    assert bag.status[-1][1]['misses'] == misses.tolist()
    poses = dict(bag.poses)
    absent = [t for t, status in bag.status if 2 in status.get('absent', [])]
    held = [(a, b) for a, b in zip(absent, absent[1:]) if a in poses and b in poses]
    for a, b in held:
        assert np.allclose(poses[a][2], poses[b][2], atol=1e-6), (a, b)
    print(f'\nkilled controller: absent after {absent_after:.1f} s wall, {misses[2]} misses '
          f'of {int(final["steps"])} steps, held still over {len(held)} sampled seconds')


def test_killed_world_metrics_node_closes_the_bag_and_the_script_names_the_world(swarm):
    run = swarm('--population', str(POPULATION), '--duration', '60', '--seed', '4')
    run.wait_running(after=3.0)
    killed_at = time.monotonic()
    os.killpg(run.nodes()['world'], signal.SIGKILL)
    status = run.wait(180)
    ended_after = time.monotonic() - killed_at

    assert status == 1, run.stderr
    assert 'FAILED world' in run.stderr and 'SIGKILL' in run.stderr
    assert 'world ended (killed by SIGKILL) during the run' in run.stderr
    # The metrics node noticed by itself, closed the bag and said so with its exit status.
    assert 'the world is lost' in run.log('metrics')
    assert 'FAILED metrics' in run.stderr and 'exit status 3' in run.stderr
    assert not no_node_left(run)
    bag = read_episode_bag(run.out / 'episode_0' / 'bag')  # strict: closed properly
    assert bag.seed == 4
    times, _ = bag.metric('mean_cue')
    assert len(times) >= 1
    print(f'\nkilled world: script done {ended_after:.1f} s after the kill; bag closed with '
          f'{len(times)} metric samples')


def test_killed_metrics_node_bag_is_recovered(swarm, tmp_path: Path):
    # One-second chunks: a SIGKILL loses at most the last second of messages.
    run = swarm('--population', str(POPULATION), '--duration', '60', '--seed', '6',
                '-p', 'chunk_period:=1.0')
    run.wait_running(after=6.0)
    os.killpg(run.nodes()['metrics'], signal.SIGKILL)
    status = run.wait(180)

    assert status == 1, run.stderr
    assert 'FAILED metrics' in run.stderr and 'SIGKILL' in run.stderr
    assert not no_node_left(run)
    bag_path = run.out / 'episode_0' / 'bag'
    with pytest.raises(TruncatedBagError):
        read_episode_bag(bag_path)
    recover = subprocess.run([str(BIN / 'mona-swarm'), 'recover', str(bag_path), '--out',
                              str(tmp_path / 'recovered')], capture_output=True, text=True,
                             timeout=120)
    assert recover.returncode == 0, recover.stderr
    bag = read_episode_bag(tmp_path / 'recovered')
    assert bag.seed == 6 and bag.announcement['population'] == POPULATION
    times, _ = bag.metric('mean_cue')
    # Whole seconds from t = 0 on, none missing up to the last salvaged sample.
    assert len(times) >= 2
    assert times.tolist() == [k * 1_000_000_000 for k in range(len(times))]
    print(f'\nkilled metrics node: recovered {len(times)} metric samples '
          f'({recover.stdout.strip()})')
