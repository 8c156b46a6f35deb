"""The solo kind: the fast controller bit for bit its plain-Python Longhand (alone and
merged, different parameters and clocks), and what the rule does in an episode: it stands
where the cue is strong, with or without a robot, and never cleans while moving."""

import numpy as np
import pytest

from mona_controller.controllers import ControllerParams, make_controller, random_readings
from mona_controller.controllers.solo import (
    STAND,
    Longhand,
    SoloController,
    SoloParams,
)
from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.runner import run_batch, run_episode
from swarm_supervisor.evolution.behaviour import behaviour

SETS = [(ControllerParams.of(SoloParams(), kind='solo'), MonaParams(), 3),
        (ControllerParams.of(SoloParams(clean_above=120.0, stand_max=0.5, leave=0.3,
                                        turn_min=0.2, turn_max=0.4), kind='solo', speed=0.04),
         MonaParams(ir_span=2.0), 2),
        (ControllerParams.of(SoloParams(alpha=5.0, clean_above=0.0, stand_max=2.0,
                                        turn_speed=0.1), kind='solo'), MonaParams(), 2)]


@pytest.mark.parametrize('seed', [0, 3])
def test_the_controller_is_its_longhand_alone_and_merged(seed):
    parts, hands, starts, first = [], [], [], 0
    for k, (params, mona, n) in enumerate(SETS):
        ids = list(range(first, first + n))
        parts.append(make_controller(params, mona, ids))
        hands += [Longhand(params, mona, robot, seed) for robot in ids]
        starts += [0.37 * k] * n
        first += n
    merged = SoloController.merge(parts)
    merged.reset(seed)
    rng = np.random.default_rng(seed + 10)
    seen = set()
    for step in range(800):
        ground, ranges, is_robot = random_readings(rng, first, MonaParams().ir_count)
        now = np.array(starts) + step * 0.032
        command = merged.step(ground, ranges, is_robot, now)
        for i, hand in enumerate(hands):
            wheels, cleaner = hand.step(ground[i].tolist(), ranges[i].tolist(),
                                        is_robot[i].tolist(), float(now[i]))
            assert command.wheels[i].tobytes() == np.array(wheels).tobytes(), (step, i)
            assert bool(command.cleaner[i]) == cleaner, (step, i)
            assert int(merged.state[i]) == hand.state, (step, i)
            assert merged.rngs[i].bit_generator.state == hand.rng.bit_generator.state
        seen |= set(merged.state.tolist())
    assert seen == {0, 1, 2, 3}  # it followed, avoided, stood and turned


def test_a_bad_section_is_refused_naming_the_key():
    with pytest.raises(ParameterError, match='controller.solo.turn_min'):
        SoloParams(turn_min=3.0, turn_max=2.0)
    with pytest.raises(ParameterError, match='controller.solo.clean_above'):
        SoloParams(clean_above=300.0)


def test_it_cleans_alone_standing_and_batches_keep_the_bits():
    config = SwarmConfig().replace(controller={'kind': 'solo'},
                                   episode={'population': 20, 'seed': 3, 'duration': 60.0})
    measured = behaviour(config)
    assert 0.0 < measured['cleaner_on'] == measured['standing'] < 1.0
    assert measured['cleaning_beside_robot'] < 0.5  # it stands where the cue is, alone
    configs = [config, config.replace(episode={'seed': 4}, world={'cleaning_quorum': 2})]
    alone = [run_episode(c) for c in configs]
    for lone, batched in zip(alone, run_batch(configs)):
        assert batched.metrics == lone.metrics
        assert np.array_equal(batched.final_cue, lone.final_cue)
    assert alone[0].metrics[-1]['mean_cue_fraction'] < 1.0
    assert STAND == 2
