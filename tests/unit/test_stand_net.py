"""The stand_net kind: its kernel bit for bit its plain-Python Longhand (alone and merged,
with clocks of their own), a stand decided once per cleaning period with one draw from the
robot's own generator, cleaning only standing, the same bits in any batch."""

import dataclasses

import numpy as np
import pytest

from mona_controller.controllers import ControllerParams, make_controller, random_readings
from mona_controller.controllers.network_weights import save_weights
from mona_controller.controllers.stand_net import (
    Longhand,
    StandNetController,
    StandNetParams,
    genome_size,
    net_arrays,
    top_command,
    weights_from_genome,
)
from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.runner import run_batch, run_episode

MONA = MonaParams()


def net(tmp_path, name, hidden, seed, **changes):
    """A stand_net section with random weights written to ``name``."""
    genome = np.random.default_rng(seed).normal(0.0, 1.5, genome_size(MONA.ir_count, hidden))
    arrays = weights_from_genome(genome, MONA.ir_count, hidden)
    arrays['w2'][2] *= 0.3  # a stand logit often within (-2, 2): p(a) strictly between 0, 1
    arrays['b2'][2] *= 0.3
    path = tmp_path / name
    save_weights(path, arrays)
    return ControllerParams.of(StandNetParams(hidden=hidden, weights=str(path), **changes),
                               kind='stand_net')


def check(controller, hands, starts, steps, seed):
    """Step both alike on random readings; demand the same bytes every step."""
    rng = np.random.default_rng(seed)
    stood = 0
    for step in range(steps):
        ground, ranges, is_robot = random_readings(rng, len(hands), MONA.ir_count)
        now = starts + step * 0.032
        command = controller.step(ground, ranges, is_robot, now)
        for i, hand in enumerate(hands):
            wheels, cleaner = hand.step(ground[i].tolist(), ranges[i].tolist(),
                                        is_robot[i].tolist(), float(now[i]))
            assert command.wheels[i].tobytes() == np.array(wheels).tobytes(), (step, i)
            assert bool(command.cleaner[i]) == cleaner, (step, i)
            assert controller.rngs[i].bit_generator.state == hand.rng.bit_generator.state
        stood += int(command.cleaner.sum())
    return stood


@pytest.mark.parametrize('needs_robot', [False, True])
def test_the_kernel_is_its_longhand_alone_and_merged(tmp_path, needs_robot):
    sets = [net(tmp_path, 'a.npz', 4, 1, needs_robot=needs_robot),
            net(tmp_path, 'b.npz', 7, 2, needs_robot=needs_robot, period=0.5)]
    parts = [make_controller(sets[0], MONA, [0, 1, 2]), make_controller(sets[1], MONA, [3, 4])]
    merged = StandNetController.merge(parts)
    merged.reset(9)
    hands = [Longhand(net_arrays(params.stand_net, MONA), MONA.ir_range,
                      top_command(params.stand_net, MONA), robot, 9,
                      params.stand_net.needs_robot, params.stand_net.period)
             for params, robot in [(sets[0], 0), (sets[0], 1), (sets[0], 2), (sets[1], 3),
                                   (sets[1], 4)]]
    stood = check(merged, hands, np.array([0.0, 0.0, 0.0, 0.7, 0.7]), 700, 4)
    assert 0 < stood < 700 * 5  # they stood some of the time, and moved some


def test_a_stand_is_decided_once_a_period_and_cleans_standing(tmp_path):
    params = net(tmp_path, 'a.npz', 5, 3)
    controller = make_controller(params, MONA, range(6))
    controller.reset(1)
    draws = [rng.bit_generator.state for rng in controller.rngs]
    rng = np.random.default_rng(2)
    for step in range(200):  # 6.4 s: decisions at 0, 1, ..., 6 s
        ground, ranges, is_robot = random_readings(rng, 6, MONA.ir_count)
        command = controller.step(ground, ranges, is_robot, step * 0.032)
        assert (command.wheels[command.cleaner] == 0.0).all()
        assert (controller.state == command.cleaner).all()  # 1 standing, 0 moving
    fresh = [np.random.default_rng([1, 1, i]) for i in range(6)]
    for generator in fresh:
        generator.random(7)
    assert [g.bit_generator.state for g in fresh] == \
        [g.bit_generator.state for g in controller.rngs] != draws


def test_weights_that_do_not_fit_are_refused_naming_the_key(tmp_path):
    path = tmp_path / 'wrong.npz'
    save_weights(path, weights_from_genome(np.zeros(genome_size(3, 4)), 3, 4))
    params = ControllerParams.of(StandNetParams(hidden=4, weights=str(path)),
                                 kind='stand_net')
    with pytest.raises(ParameterError, match='controller.stand_net.weights'):
        make_controller(params, MONA, [0])


def test_episodes_alone_equal_episodes_in_a_batch(tmp_path):
    base = SwarmConfig().replace(episode={'population': 12, 'duration': 40.0})
    configs = [dataclasses.replace(base, controller=net(tmp_path, f'{k}.npz', 3 + k, k))
               .replace(episode={'seed': 5 + k}) for k in range(3)]
    configs.append(configs[0].replace(world={'cleaning_quorum': 2}))
    alone = [run_episode(config) for config in configs]
    for lone, batched in zip(alone, run_batch(configs)):
        assert batched.metrics == lone.metrics
        assert np.array_equal(batched.final_poses, lone.final_poses)
    assert alone[0].metrics[-1]['mean_cue_fraction'] < 1.0  # it cleaned
