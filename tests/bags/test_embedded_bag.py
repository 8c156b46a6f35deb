"""One record format: the embedded runner's bag (``mona-swarm run --bag``) against the bag the
metrics node records of a lockstep run of scripts/swarm.sh with the same seed.

Same topics, types, offered QoS and custom_data; identical poses, the controllers' states,
cleaning events, cue maps, sources and metrics, decoded once with rosbags and once with an
independent decoder (mcap + mcap-ros2-support); also with moving leaks and with a command
latency (``sensing.command_latency``).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader

from mona_controller import topics
from swarm_metrics.bags.reader import read_custom_data, read_episode_bag
from swarm_metrics.ros.metrics_node import MetricsNodeParams
from swarm_supervisor.config import load_config, write_ros_yaml
from swarm_supervisor.engine.runner import run_episode
from swarm_supervisor.outputs.bag import TOPICS, BagOptions, record_episode
from swarm_world.messages.cdr import TYPESTORE

from swarmrun import CONFIG, SwarmRun

pytestmark = pytest.mark.ros

POPULATION, DURATION, SEED = 8, 16.0, 1
ROBOT_STATES, SOURCES = topics.ROBOT_STATES, topics.SOURCES
#: What the comparison covers: everything but the world's status documents (the embedded
#: one says mode "embedded").
COMPARED = ('/world/poses', '/world/cleaning', '/world/cue_map', '/episode', '/world/obstacles',
            ROBOT_STATES, SOURCES,
            *(f'/metrics/{name}' for name in ('mean_cue', 'mean_cue_fraction',
                                              'ratio_near_source', 'coherency')))


@pytest.fixture(scope='module')
def bags(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(the lockstep run's bag, the embedded run's bag) of the same episode."""
    run = SwarmRun(tmp_path_factory.mktemp('lockstep') / 'run',
                   ['--population', str(POPULATION), '--duration', str(DURATION),
                    '--seed', str(SEED), '--mode', 'lockstep'])
    try:
        status = run.wait()
    finally:
        run.stop()
    assert status == 0, run.stderr
    config = load_config(CONFIG).replace(
        episode={'population': POPULATION, 'duration': DURATION, 'seed': SEED})
    _, closed = record_episode(config, tmp_path_factory.mktemp('embedded'))
    return run.out / 'episode_0' / 'bag', closed.path


def mcap_messages(bag: Path) -> dict[str, list[tuple[int, object]]]:
    """topic -> [(log time from the episode start, decoded message)], by mcap-ros2-support."""
    out: dict[str, list[tuple[int, object]]] = {}
    with open(next(bag.glob('*.mcap')), 'rb') as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages():
            out.setdefault(channel.topic, []).append((message.log_time, decoded))
    start = json.loads(out['/episode'][0][1].data)['start_ns']
    return {topic: [(t - start, m) for t, m in items] for topic, items in out.items()}


def plain(topic: str, msg) -> object:
    """The content of a decoded message (either decoder) as plain Python values."""
    if topic in ('/world/poses', '/world/cleaning'):
        return ((msg.header.stamp.sec, msg.header.stamp.nanosec),
                [(p.position.x, p.position.y, p.orientation.z, p.orientation.w)
                 for p in msg.poses])
    if topic == '/world/cue_map':
        return ((msg.header.stamp.sec, msg.header.stamp.nanosec), msg.height, msg.width,
                msg.encoding, bytes(msg.data))
    if topic in ('/world/obstacles', SOURCES):  # no obstacles here; the sources move
        return [(m.ns, m.id, m.type, m.text, (m.header.stamp.sec, m.header.stamp.nanosec),
                 m.pose.position.x, m.pose.position.y, m.pose.position.z, m.scale.x,
                 m.scale.y, (m.color.r, m.color.g, m.color.b, m.color.a),
                 [(p.x, p.y) for p in m.points]) for m in msg.markers]
    if topic == ROBOT_STATES:
        return bytes(msg.data), [(d.label, d.size, d.stride) for d in msg.layout.dim], \
            msg.layout.data_offset
    if topic == '/episode':
        document = json.loads(msg.data)
        return {key: value for key, value in document.items() if key != 'start_ns'}
    return msg.data  # Float64


def test_the_embedded_bag_has_the_metrics_node_topics_types_and_qos(bags):
    node_bag, embedded_bag = bags
    assert BagOptions().cue_map_period == MetricsNodeParams().cue_map_period
    assert BagOptions().clock_period == MetricsNodeParams().clock_period

    def connections(bag: Path) -> tuple[dict, dict]:
        with Reader(bag) as reader:
            return ({c.topic: (c.msgtype, c.ext.offered_qos_profiles)
                     for c in reader.connections}, read_custom_data(bag))

    node_topics, node_custom = connections(node_bag)
    embedded_topics, embedded_custom = connections(embedded_bag)
    # Both bags hold the contract's recorded topics with its types and QoS, the robots'
    # states and the sources included.
    assert embedded_topics == {topic: (msgtype, [offered])
                               for topic, (msgtype, offered) in TOPICS.items()}
    assert {ROBOT_STATES, SOURCES} <= set(node_topics)
    assert embedded_topics == node_topics
    assert set(embedded_custom) == set(node_custom)
    for key in ('mona_swarm.seed', 'mona_swarm.population', 'mona_swarm.duration',
                'mona_swarm.parameters'):
        assert json.loads(embedded_custom[key]) == json.loads(node_custom[key]), key


def test_both_runners_record_identical_poses_cleaning_and_metrics_mcap_decoder(bags):
    node, embedded = (mcap_messages(bag) for bag in bags)
    for topic in COMPARED:
        assert [(t, plain(topic, m)) for t, m in embedded[topic]] == \
            [(t, plain(topic, m)) for t, m in node[topic]], topic
    # Not two idle worlds: the robots moved and cleaned.
    assert len(node['/world/cleaning']) > 0
    assert len(node['/world/poses']) == int(DURATION)
    # The controller nodes' states, gathered by the world: at t = 0, each sampled pose and
    # the end, as the embedded runner's.
    states = [np.frombuffer(bytes(m.data), np.uint8) for _, m in node[ROBOT_STATES]]
    assert len(states) == int(DURATION) + 1 and all(len(s) == POPULATION for s in states)
    assert {int(s) for row in states for s in row} >= {0, 2}  # some followed, some waited
    assert [t for t, _ in node[ROBOT_STATES]][1:] == [t for t, _ in node['/world/poses']]
    # The sources as often as the cue map: t = 0, the first map at or after 10 s, the end.
    assert [t for t, _ in node[SOURCES]] == [t for t, _ in node['/world/cue_map']]
    assert [t // 10**10 for t, _ in node[SOURCES]] == [0, 1, 1]


def rosbags_messages(bag: Path) -> dict[str, list[tuple[int, object]]]:
    """As :func:`mcap_messages`, read and decoded by rosbags."""
    out: dict[str, list[tuple[int, object]]] = {}
    with Reader(bag) as reader:
        for connection, log_ns, raw in reader.messages():
            out.setdefault(connection.topic, []).append(
                (log_ns, TYPESTORE.deserialize_cdr(raw, connection.msgtype)))
    start = json.loads(out['/episode'][0][1].data)['start_ns']
    return {topic: [(t - start, m) for t, m in items] for topic, items in out.items()}


def test_both_runners_record_identical_poses_cleaning_and_metrics_rosbags(bags):
    node, embedded = (rosbags_messages(bag) for bag in bags)
    for topic in COMPARED:
        assert [(t, plain(topic, m)) for t, m in embedded[topic]] == \
            [(t, plain(topic, m)) for t, m in node[topic]], topic
    # The project's own reader agrees (what analyze and replay use).
    np.testing.assert_array_equal(read_episode_bag(bags[0]).metric('coherency')[1],
                                  read_episode_bag(bags[1]).metric('coherency')[1])


def test_analyze_takes_the_embedded_bag(bags, tmp_path):
    result = subprocess.run([sys.executable, '-m', 'swarm_supervisor.cli', 'analyze',
                             str(bags[1]), '--out', str(tmp_path / 'analysed')],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert 'online metrics agree to 0' in result.stdout


#: Two moving, leaking sources on a diffusing, evaporating field (docs/model.md).
LEAKS = {'sources': {'west': [0.9, 1.9, 0.5, 255.0], 'east': [2.0, 0.9, 0.45, 230.0]},
         'source_profile': {'east': ['gaussian']},
         'source_emission': {'west': [4.0], 'east': [3.0]},
         'source_velocity': {'west': [0.02, 0.01]},
         'source_path': {'east': [0.03, 2.3, 1.5, 1.6, 1.2]},
         'diffusion': 5e-5, 'half_life': 60.0, 'transport_period': 0.5}


@pytest.fixture(scope='module')
def leak_bags(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(lockstep bag, embedded bag) of one episode of the moving-leaks scenario."""
    config = load_config(CONFIG).replace(
        world=LEAKS, episode={'population': 12, 'duration': 12.0, 'seed': 3})
    folder = tmp_path_factory.mktemp('leaks')
    write_ros_yaml(config, folder / 'leaks.yaml')
    # Four controllers per process: the layout is not what this compares (the default one
    # process per robot is the fixture ``bags``'), and each process costs a start-up.
    run = SwarmRun(folder / 'run', ['--config', str(folder / 'leaks.yaml'), '--mode',
                                    'lockstep', '--controllers-per-process', '4'])
    try:
        status = run.wait()
    finally:
        run.stop()
    assert status == 0, run.stderr
    _, closed = record_episode(config, tmp_path_factory.mktemp('leaks_embedded'))
    return run.out / 'episode_0' / 'bag', closed.path


def test_a_moving_leaking_field_records_the_same_bag_in_both_runners(leak_bags, tmp_path):
    node, embedded = (mcap_messages(bag) for bag in leak_bags)
    for topic in COMPARED:
        assert [(t, plain(topic, m)) for t, m in embedded[topic]] == \
            [(t, plain(topic, m)) for t, m in node[topic]], topic
    maps = [np.frombuffer(bytes(m.data), np.uint8) for _, m in node['/world/cue_map']]
    assert len(node['/world/cleaning']) > 0 and len(maps) >= 3
    assert not np.array_equal(maps[1], maps[-1])  # the field evolved
    where = [[(m.text, m.pose.position.x, m.pose.position.y) for m in msg.markers]
             for _, msg in node[SOURCES]]
    assert [name for name, _, _ in where[0]] == ['east', 'west'] and where[0] != where[-1]
    # The record stays checkable: analyze rebuilds every cue map from the cleaning record
    # and the announced parameters (diffusion, evaporation, emission, motion) exactly.
    result = subprocess.run([sys.executable, '-m', 'swarm_supervisor.cli', 'analyze',
                             str(leak_bags[0]), '--out', str(tmp_path / 'analysed')],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'online metrics agree to 0' in result.stdout
    header = (tmp_path / 'analysed' / 'metrics.csv').read_text().splitlines()[0]
    assert header.endswith('mean_cue_fraction_east,ratio_near_east,'  # in name order
                           'mean_cue_fraction_west,ratio_near_west')


#: A radio link's timing (docs/model.md, "The real link"): commands reach the wheels 3 control
#: steps of 2 world steps late, the real Monas' IR range.
LATENCY = {'mona': {'ir_range': 0.02}, 'sensing': {'command_latency': 3},
           'world': {'control_steps': 2}}


@pytest.fixture(scope='module')
def latency_bags(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(lockstep bag, embedded bag) of one episode with a command latency."""
    config = load_config(CONFIG).replace(
        **LATENCY, episode={'population': POPULATION, 'duration': 12.0, 'seed': 2})
    folder = tmp_path_factory.mktemp('latency')
    write_ros_yaml(config, folder / 'latency.yaml')
    # Four controllers per process: the layout is not what this compares (the default one
    # process per robot is the fixture ``bags``'), and each process costs a start-up.
    run = SwarmRun(folder / 'run', ['--config', str(folder / 'latency.yaml'), '--mode',
                                    'lockstep', '--controllers-per-process', '4'])
    try:
        status = run.wait()
    finally:
        run.stop()
    assert status == 0, run.stderr
    _, closed = record_episode(config, tmp_path_factory.mktemp('latency_embedded'))
    return run.out / 'episode_0' / 'bag', closed.path


def test_a_command_latency_records_the_same_bag_in_both_runners(latency_bags):
    node, embedded = (mcap_messages(bag) for bag in latency_bags)
    for topic in COMPARED:
        assert [(t, plain(topic, m)) for t, m in embedded[topic]] == \
            [(t, plain(topic, m)) for t, m in node[topic]], topic
    assert len(node['/world/cleaning']) > 0
    parameters = json.loads(node['/episode'][0][1].data)['parameters']
    assert parameters['sensing']['command_latency'] == 3
    # The latency took effect: without it the same episode moves otherwise.
    config = load_config(CONFIG).replace(
        mona={'ir_range': 0.02}, world={'control_steps': 2},
        episode={'population': POPULATION, 'duration': 12.0, 'seed': 2})
    delayed = run_episode(config.replace(sensing={'command_latency': 3}))
    assert not np.array_equal(run_episode(config).final_poses, delayed.final_poses)
