"""A whole ros run in this process: supervisor, world and controller nodes in one executor,
driven from Python through the Supervisor class. Lockstep reproduces the embedded runner."""

from __future__ import annotations

import json

import numpy as np
import pytest
from rclpy.parameter import Parameter

from mona_controller.ros.controller_node import ControllerNode
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.runner import run_episode
from swarm_supervisor.system.ros.supervisor_node import RUN_FILE, Supervisor
from swarm_world.hosting import FINAL_FILE
from swarm_world.ros.world_node import WorldNode

pytestmark = pytest.mark.ros

POPULATION, DURATION, SEED = 20, 4.0, 4  # with encounters and cleaning in episode 0


def test_two_episodes_match_the_embedded_runner(executor, spin_until, tmp_path):
    episode = [Parameter('episode.population', value=POPULATION),
               Parameter('episode.duration', value=DURATION),
               Parameter('episode.seed', value=SEED)]
    out = Parameter('output_dir', value=str(tmp_path))
    context = executor.context
    world = WorldNode(context=context, parameter_overrides=[out])
    controllers = [ControllerNode(i, context=context) for i in range(POPULATION)]
    supervisor = Supervisor(context=context, parameter_overrides=[
        *episode, out, Parameter('episodes', value=2)])
    for node in (world, *controllers, supervisor):
        executor.add_node(node)

    supervisor.run()  # two episodes, then the shutdown announcement
    spin_until(lambda: world.finished.done() and all(c.finished.done() for c in controllers),
               what='every node told to shut down')

    record = json.loads((tmp_path / RUN_FILE).read_text())
    episodes = record['episodes']
    assert [e['seed'] for e in episodes] == [SEED, SEED + 1]
    assert episodes[1]['start_ns'] == episodes[0]['end_ns'] > 0  # sim time carries on
    assert record['parameters']['episode']['population'] == POPULATION
    for k, seed in enumerate((SEED, SEED + 1)):
        config = SwarmConfig().replace(episode={'population': POPULATION,
                                                'duration': DURATION, 'seed': seed})
        embedded = run_episode(config)
        final = np.load(tmp_path / f'episode_{k}' / FINAL_FILE)
        assert int(final['seed']) == seed and final['misses'].sum() == 0
        assert int(final['steps']) == embedded.steps == episodes[k]['steps']
        assert np.array_equal(final['poses'], embedded.final_poses), k
        assert np.array_equal(final['cue'], embedded.final_cue), k
        assert embedded.encounters > 0
    # Episode 0 cleaned part of the cue (eq. 3 ran through /cleaner and the world).
    assert not np.array_equal(np.load(tmp_path / 'episode_0' / FINAL_FILE)['cue'],
                              world.world.initial_cue)


#: Parameter sets off their defaults that every node must apply as the embedded runner does.
MODELS = {
    # The sweepable decisions and the noise streams, drawn in the world from the seed.
    'decisions-and-noise': {
        'mona.ir_range': 0.06, 'mona.ir_count': 7, 'sensing.ground_footprint': 0.03,
        'controller.beeclust.avoid': 'random-turn', 'controller.beeclust.alpha': 10.0,
        'world.cleaning': 'literal',
        'sensing.ground_noise': 6.0, 'sensing.ir_miss': 0.1, 'sensing.wheel_noise': 0.05},
    # The controllers answer every third step; the world holds their commands between.
    'control-period': {'world.control_steps': 3, 'sensing.ground_noise': 3.0},
    # The cleaning as a Webots Display blends it, on a raster of its 3.9 mm pixels.
    'display-cleaning': {'world.cleaning': 'blend', 'world.cell_size': 0.00390625},
    # Ground sensors as Webots infra-red sensors, 6 cm apart and 3 cm ahead of the axle.
    'webots-ground': {'sensing.ground_transfer': 'webots', 'sensing.ground_baseline': 0.06,
                      'sensing.ground_offset': 0.03},
    # A dark body seen near contact, robot or wall told by place.
    'encounter-model': {'sensing.robot_detection': 'position', 'sensing.ir_robot_factor': 0.3,
                        'sensing.ir_miss': 0.1},
    # Turns in place at the robot's own speed.
    'turn-at-speed': {'controller.beeclust.turn_at': 'speed',
                      'controller.beeclust.wait_max': 5.0},
    # A radio link's delay: each command reaches the wheels 3 control steps (of 2) later.
    'command-latency': {'sensing.command_latency': 3, 'world.control_steps': 2},
}


@pytest.mark.parametrize('name', sorted(MODELS))
def test_non_default_model_parameters_match_the_embedded_runner(executor, spin_until,
                                                                tmp_path, name):
    """A lockstep episode with parameters off their defaults equals the embedded runner with
    the same parameters: each reaches every node."""
    model = MODELS[name]
    population, duration, seed = 12, 6.0, 5
    overrides = [Parameter(key, value=value) for key, value in model.items()]
    overrides += [Parameter('episode.population', value=population),
                  Parameter('episode.duration', value=duration),
                  Parameter('episode.seed', value=seed),
                  Parameter('output_dir', value=str(tmp_path))]
    context = executor.context
    world = WorldNode(context=context, parameter_overrides=overrides)
    controllers = [ControllerNode(i, context=context, parameter_overrides=overrides)
                   for i in range(population)]
    supervisor = Supervisor(context=context, parameter_overrides=[
        *overrides, Parameter('episodes', value=1)])
    for node in (world, *controllers, supervisor):
        executor.add_node(node)
    supervisor.run()
    spin_until(lambda: world.finished.done() and all(c.finished.done() for c in controllers),
               what='every node told to shut down')

    sections: dict[str, dict] = {'episode': {'population': population, 'duration': duration,
                                             'seed': seed}}
    embedded = run_episode(SwarmConfig().replace(**sections).with_values(model))
    final = np.load(tmp_path / 'episode_0' / FINAL_FILE)
    assert int(final['steps']) == embedded.steps and final['misses'].sum() == 0
    assert np.array_equal(final['poses'], embedded.final_poses)
    assert np.array_equal(final['cue'], embedded.final_cue)
    # The parameters took effect: the default model runs differently.
    default = run_episode(SwarmConfig().replace(episode=sections['episode']))
    assert not np.array_equal(default.final_poses, embedded.final_poses)


def test_an_announcement_is_compared_as_parameters_naming_the_keys(executor, tmp_path):
    """A driver's announcement that leaves keys at their defaults is the same model; one that
    differs is refused naming the key, not by printing two whole sections."""
    from mona_controller.contract import Announcement
    world = WorldNode(context=executor.context,
                      parameter_overrides=[Parameter('output_dir', value=str(tmp_path))])
    try:
        shipped = {'body_radius': 0.04, 'ir_count': 5}  # ir_range etc. left out
        same = Announcement(episode=0, seed=1, population=2, duration=1.0,
                            parameters={'mona': shipped, 'world': {'arena_side': 2.85}})
        assert world._check_announcement(same) == ''
        other = Announcement(episode=0, seed=1, population=2, duration=1.0,
                             parameters={'mona': {**shipped, 'ir_range': 0.05}})
        problem = world._check_announcement(other)
        assert 'mona.ir_range: announced 0.05, here 0.03' in problem
        assert 'body_radius' not in problem
    finally:
        world.destroy_node()


#: One obstacle of each kind, clear of the source at the centre.
OBSTACLES = {'pillar': [0.9, 0.9, 0.1], 'wall': [2.2, 0.3, 2.26, 1.1],
             'wedge': [0.3, 2.3, 0.7, 2.5, 0.35, 2.6]}


def bag_messages(bag) -> dict[str, list[tuple[int, object]]]:
    """topic -> [(log time, message)] of a bag, decoded by mcap-ros2-support (a decoder that
    is not the project's)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out: dict[str, list[tuple[int, object]]] = {}
    with open(next(bag.glob('*.mcap')), 'rb') as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages():
            out.setdefault(channel.topic, []).append((message.log_time, decoded))
    return out


def marker_fields(msg) -> list[tuple]:
    """Every field of a MarkerArray's markers that /world/obstacles fills."""
    return [(m.ns, m.id, m.type, m.action, m.header.frame_id, m.header.stamp.sec,
             m.header.stamp.nanosec, m.text, (m.pose.position.x, m.pose.position.y,
                                              m.pose.position.z),
             (m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z,
              m.pose.orientation.w), (m.scale.x, m.scale.y, m.scale.z),
             (m.color.r, m.color.g, m.color.b, m.color.a),
             [(p.x, p.y, p.z) for p in m.points]) for m in msg.markers]


def test_obstacles_reach_the_metrics_nodes_bag_as_the_embedded_runner_records_them(
        executor, spin_until, tmp_path):
    """A lockstep episode among obstacles, recorded by the metrics node in this process: its
    bag holds the world's /world/obstacles once, at the episode's start, equal to the embedded
    runner's bag, and the episodes themselves are equal."""
    from swarm_metrics.ros.metrics_node import MetricsNode
    from swarm_supervisor.outputs.bag import record_episode

    population, duration, seed = 8, 3.0, 2
    overrides = [Parameter(f'world.obstacles.{name}', value=values)
                 for name, values in OBSTACLES.items()]
    overrides += [Parameter('episode.population', value=population),
                  Parameter('episode.duration', value=duration),
                  Parameter('episode.seed', value=seed)]
    recorders = Parameter('recorders', value='metrics')
    out = Parameter('output_dir', value=str(tmp_path / 'ros'))
    context = executor.context
    world = WorldNode(context=context, parameter_overrides=[*overrides, out, recorders])
    metrics = MetricsNode(context=context, parameter_overrides=[out])
    controllers = [ControllerNode(i, context=context, parameter_overrides=overrides)
                   for i in range(population)]
    supervisor = Supervisor(context=context, parameter_overrides=[
        *overrides, out, recorders, Parameter('episodes', value=1)])
    for node in (world, metrics, *controllers, supervisor):
        executor.add_node(node)
    supervisor.run()
    spin_until(lambda: world.finished.done() and metrics.done.done(),
               what='the world and the metrics node told to shut down')

    config = SwarmConfig().replace(world={'obstacles': OBSTACLES}, episode={
        'population': population, 'duration': duration, 'seed': seed})
    _, closed = record_episode(config, tmp_path / 'embedded')
    node, embedded = (bag_messages(bag) for bag in (tmp_path / 'ros' / 'episode_0' / 'bag',
                                                    closed.path))
    (node_time, node_msg), = node['/world/obstacles']
    (embedded_time, embedded_msg), = embedded['/world/obstacles']
    start = json.loads(node['/episode'][0][1].data)['start_ns']
    assert node_time == start and embedded_time == 0  # at the episode's start
    assert marker_fields(node_msg) == marker_fields(embedded_msg)
    assert [(m.id, m.text, m.type) for m in node_msg.markers] == [
        (0, 'pillar', 3), (1, 'wall', 1), (2, 'wedge', 11)]
    # The episode ran among them alike in both runners.
    final = np.load(tmp_path / 'ros' / 'episode_0' / FINAL_FILE)
    assert np.array_equal(final['poses'], run_episode(config).final_poses)
