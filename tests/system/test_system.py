"""The node system as real processes, started by scripts/swarm.sh: a 20 s lockstep episode of
five robots (625 steps, 3 encounters) and what it leaves behind (the bag, the parity with the
embedded runner, the online metrics), bad parameters, and Ctrl-C / SIGTERM / SIGKILL to the
script."""

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
import yaml
from mcap.reader import make_reader
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from swarm_metrics.bags.reader import read_episode_bag
from swarm_supervisor.config import load_config
from swarm_supervisor.engine.runner import run_episode
from swarm_supervisor.outputs.episode_folder import read_metrics_csv

from swarmrun import CONFIG, SWARM, SwarmRun, group_alive

pytestmark = pytest.mark.ros

POPULATION, DURATION, SEED = 5, 20.0, 7
METRICS = ('mean_cue', 'mean_cue_fraction', 'ratio_near_source', 'coherency')
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)


@pytest.fixture(scope='module')
def finished(tmp_path_factory: pytest.TempPathFactory):
    """One lockstep episode (N = 5, 20 s, seed 7) run to the end; (run, exit status)."""
    run = SwarmRun(tmp_path_factory.mktemp('lockstep') / 'run',
                   ['--population', str(POPULATION), '--duration', str(DURATION),
                    '--seed', str(SEED), '--mode', 'lockstep'])
    try:
        run.wait_running()
        run.note_shm()
        status = run.wait()
        yield run, status
    finally:
        run.stop()


def bag_dir(run: SwarmRun, episode: int = 0) -> Path:
    return run.out / f'episode_{episode}' / 'bag'


def test_run_finishes_and_leaves_nothing_behind(finished):
    run, status = finished
    assert status == 0, run.stderr
    assert 'done' in run.stderr
    nodes = run.nodes()
    assert set(nodes) == {'world', 'metrics', 'supervisor',
                          *(f'controller_{i}' for i in range(POPULATION))}
    assert not [name for name, pgid in nodes.items() if group_alive(pgid)]
    assert not run.seen_shm  # the localhost profile: UDP only, no shared memory
    assert not run.shm_leftovers()
    record = json.loads((run.out / 'run.json').read_text())
    assert record['seed'] == SEED
    assert record['episodes'][0]['misses'] == 0
    for name in nodes:
        assert (run.out / 'logs' / f'{name}.log').exists()


def test_bag_opens_with_rosbags_and_mcap(finished):
    run, status = finished
    assert status == 0, run.stderr
    path = bag_dir(run)
    with Reader(path) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
        counts: dict[str, int] = {}
        metric_times = []
        for connection, log_ns, raw in reader.messages():
            counts[connection.topic] = counts.get(connection.topic, 0) + 1
            if connection.topic == '/metrics/mean_cue':
                metric_times.append(log_ns)
            if connection.topic == '/episode':
                announcement = json.loads(
                    TYPESTORE.deserialize_cdr(raw, connection.msgtype).data)
        assert reader.message_count == sum(counts.values())
    info = yaml.safe_load((path / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['storage_identifier'] == 'mcap'
    custom = info['custom_data']
    assert topics['/episode'] == 'std_msgs/msg/String'
    assert topics['/world/poses'] == 'geometry_msgs/msg/PoseArray'
    assert topics['/world/status'] == 'std_msgs/msg/String'
    assert topics['/world/cue_map'] == 'sensor_msgs/msg/Image'
    for name in METRICS:
        assert topics[f'/metrics/{name}'] == 'std_msgs/msg/Float64'
    # One sample per simulated second, t = 0 .. 20 s, logged at the sim time it describes.
    assert metric_times == [k * 1_000_000_000 for k in range(int(DURATION) + 1)]
    assert all(counts[f'/metrics/{name}'] == int(DURATION) + 1 for name in METRICS)
    assert announcement['seed'] == SEED and announcement['population'] == POPULATION
    assert json.loads(custom['mona_swarm.seed']) == SEED
    assert json.loads(custom['mona_swarm.parameters'])['controller']['speed'] == 0.08

    # The mcap library, independently of rosbags, reads the same messages.
    with open(path / 'bag.mcap', 'rb') as handle:
        reader = make_reader(handle)
        by_topic: dict[str, int] = {}
        for _, channel, _ in reader.iter_messages():
            by_topic[channel.topic] = by_topic.get(channel.topic, 0) + 1
        summary = reader.get_summary()
        assert summary.statistics.message_count == sum(counts.values())
        assert {index.compression for index in summary.chunk_indexes} == {'zstd'}
    assert by_topic == counts


def test_lockstep_matches_the_embedded_runner(finished):
    """Same seed and parameters: the same final poses and cue map, bit for bit."""
    run, status = finished
    assert status == 0, run.stderr
    final = np.load(run.out / 'episode_0' / 'world_final.npz')
    assert int(final['seed']) == SEED
    assert not final['misses'].any() and int(final['dropped']) == 0
    config = load_config(CONFIG).replace(
        episode={'population': POPULATION, 'duration': DURATION, 'seed': SEED})
    embedded = run_episode(config)
    assert int(final['steps']) == embedded.steps
    np.testing.assert_array_equal(final['poses'], embedded.final_poses)
    np.testing.assert_array_equal(final['cue'], embedded.final_cue.astype(np.float32))
    # The robots moved and cleaned: the comparison is not between two idle worlds.
    assert not np.allclose(embedded.final_poses, embedded.initial_poses)
    # The metrics node's online samples equal the embedded runner's.
    bag = read_episode_bag(bag_dir(run))
    for name in METRICS:
        times, values = bag.metric(name)
        np.testing.assert_allclose(values, [row[name] for row in embedded.metrics],
                                   rtol=1e-12, atol=1e-12, err_msg=name)


def test_real_time_factor_holds_lockstep_to_the_wall_clock_with_the_same_bits(swarm):
    """-p real_time_factor:=2.0: 4 sim seconds take at least 2 wall seconds from the
    episode's start to its end (unpaced, 2 robots step them in well under a second), and land
    where the embedded runner does. (The pace counts from step 0's round, which the world
    logs 'running' before: from its 'step 0 done' line, which comes after that round's
    answers, a loaded machine left 1.86 s, ci24.)"""
    run = swarm('--population', '2', '--duration', '4', '--seed', '5',
                '-p', 'real_time_factor:=2.0')
    assert run.wait(120) == 0, run.stderr + run.failed_logs()
    stamps = {}  # the world's log lines carry their wall time in ns: [INFO] [<s.ns>] ...
    for line in run.log('world').splitlines():
        for what in ('episode 0 running', 'finished at'):
            if what in line:
                stamps[what] = float(line.split('[')[2].split(']')[0])
    assert stamps['finished at'] - stamps['episode 0 running'] >= 2.0 - 0.1, stamps
    final = np.load(run.out / 'episode_0' / 'world_final.npz')
    config = load_config(CONFIG).replace(episode={'population': 2, 'duration': 4.0, 'seed': 5})
    np.testing.assert_array_equal(final['poses'], run_episode(config).final_poses)


def test_online_metrics_equal_what_analyze_recomputes(finished, tmp_path: Path):
    run, status = finished
    assert status == 0, run.stderr
    analyze = subprocess.run(
        [str(Path(sys.executable).parent / 'mona-swarm'), 'analyze', str(bag_dir(run)),
         '--out', str(tmp_path / 'analysis')], capture_output=True, text=True, timeout=180)
    assert analyze.returncode == 0, analyze.stderr
    recomputed = read_metrics_csv(tmp_path / 'analysis' / 'metrics.csv')
    online = read_episode_bag(bag_dir(run))
    for name in METRICS:
        times, values = online.metric(name)
        np.testing.assert_array_equal(recomputed['t'], times / 1e9)
        np.testing.assert_array_equal(recomputed[name], values, err_msg=name)
    record = json.loads((tmp_path / 'analysis' / 'episode.json').read_text())
    assert record['complete'] is True


def test_out_of_range_controller_parameter_fails_clearly(processes):
    node = processes.spawn(
        ['mona_controller_node', '--robots', '0', '--ros-args', '--params-file', str(CONFIG),
         '-p', 'controller.speed:=3.0'], 'controller')
    assert node.wait(60) == 2  # bad parameter
    log = processes.log('controller')
    assert 'controller.speed = 3.0 is out of range' in log and '[0, 1] m/s' in log


def test_swarm_script_rejects_a_bad_speed_before_starting(tmp_path: Path):
    out = tmp_path / 'never'
    result = subprocess.run([str(SWARM), '--speed', '300', '--out', str(out)],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert 'controller.speed = 3.0 is out of range' in result.stderr
    assert not out.exists()  # nothing started, nothing written


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_signal_to_the_script_stops_everything_and_keeps_the_bag(swarm, sig):
    run = swarm('--population', str(POPULATION), '--duration', '60', '--seed', '3')
    run.wait_running(after=3.0)
    assert not run.note_shm()
    os.kill(run.process.pid, sig)
    status = run.wait(120)
    assert status == 128 + sig, run.stderr + run.failed_logs()
    assert f'{sig.name} received' in run.stderr
    # every node stopped on the first signal
    assert 'FAILED' not in run.stderr, run.stderr + run.failed_logs()
    assert not [name for name, pgid in run.nodes().items() if group_alive(pgid)]
    assert not run.shm_leftovers()
    bag = read_episode_bag(bag_dir(run))  # strict: a bag closed properly
    assert bag.seed == 3
    assert len(bag.metric('mean_cue')[0]) >= 1
    with Reader(bag_dir(run)) as reader:
        assert reader.message_count > 0
    assert 'closed' in run.log('metrics')


def test_a_script_killed_outright_leaves_no_node_and_a_closed_bag(swarm):
    """kill -9 of scripts/swarm.sh (the launcher it execs): no stop ladder can run, but each
    node gets SIGINT as the launcher ends (Linux's parent-death signal, which the launcher
    asks for as it starts them), so all end and the metrics node closes its bag. Before
    2026-12-05 the nodes ran on."""
    # 1000 s of sim time: minutes of wall time, so the nodes cannot end by finishing it.
    run = swarm('--population', '2', '--duration', '1000', '--seed', '4')
    run.wait_running(after=0.5)
    os.kill(run.process.pid, signal.SIGKILL)
    assert run.wait(30) == -signal.SIGKILL
    deadline = time.monotonic() + 30
    while alive := [name for name, pgid in run.nodes().items() if group_alive(pgid)]:
        assert time.monotonic() < deadline, f'still running 30 s after the launcher: {alive}'
        time.sleep(0.25)
    assert len(run.nodes()) == 2 + 3  # world, metrics, supervisor, the controllers
    bag = read_episode_bag(bag_dir(run))  # strict: a bag closed properly
    assert bag.seed == 4
    assert 'closed' in run.log('metrics')
    assert not run.shm_leftovers()

