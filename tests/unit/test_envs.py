"""The learning environments: PettingZoo's and Gymnasium's API checks, whole episodes that
repeat bit for bit from a seed, and BEECLUST's answers as actions reproducing the embedded
runner and the batched engine exactly."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test, parallel_seed_test

from mona_controller.controllers import make_controller
from swarm_supervisor.config import load_config
from swarm_supervisor.engine.runner import run_batch, run_episode
from swarm_supervisor.envs import (
    EnvError,
    MonaSwarmParallelEnv,
    MonaSwarmVectorEnv,
    commands_from_actions,
    observations,
)
from swarm_supervisor.media.video import OBSTACLE_FILL

SMALL = load_config().replace(episode={'population': 8, 'duration': 20.0, 'seed': 3})


def _beeclust_actions(controller, readings) -> np.ndarray:
    command = controller.step(readings.ground, readings.ranges, readings.is_robot,
                              readings.now)
    return np.column_stack([command.wheels, command.cleaner.astype(np.float64)])


def test_the_parallel_env_passes_pettingzoo_api_and_seed_tests():
    config = SMALL.replace(episode={'population': 4, 'duration': 3.0})
    parallel_api_test(MonaSwarmParallelEnv(config), num_cycles=120)
    parallel_seed_test(lambda: MonaSwarmParallelEnv(config))


def _random_episode_hash(seed: int) -> str:
    env = MonaSwarmParallelEnv(SMALL)
    observed, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    digest = hashlib.sha256()
    while env.agents:
        actions = {agent: env.action_space(agent).low + rng.random(3)
                   * (env.action_space(agent).high - env.action_space(agent).low)
                   for agent in env.agents}
        observed, rewards, _, _, _ = env.step(actions)
        for agent in env.possible_agents:
            digest.update(observed[agent].tobytes())
        digest.update(np.float64(sum(rewards.values())).tobytes())
    digest.update(env.state().tobytes())
    return digest.hexdigest()


def test_a_whole_episode_repeats_bit_for_bit_from_its_seed():
    assert _random_episode_hash(5) == _random_episode_hash(5)
    assert _random_episode_hash(5) != _random_episode_hash(6)


@pytest.mark.parametrize('control_steps', [1, 3])
def test_beeclust_through_the_env_is_the_embedded_runner(control_steps):
    config = SMALL.replace(world={'control_steps': control_steps})
    env = MonaSwarmParallelEnv(config)
    env.reset(seed=config.episode.seed)
    controller = make_controller(config.controller, config.mona,
                                 range(config.episode.population))
    controller.reset(config.episode.seed)
    total = 0.0
    while env.agents:
        actions = _beeclust_actions(controller, env.readings)
        _, rewards, terminations, truncations, _ = env.step(
            {agent: actions[i] for i, agent in enumerate(env.agents)})
        total += rewards['mona_0']
        assert not any(terminations.values())
    assert all(truncations.values())
    expected = run_episode(config)
    assert env.metrics == expected.metrics
    assert np.array_equal(env.episode.world.poses, expected.final_poses)
    # The return is the share of the cue cleaned (rewards telescope).
    assert total == pytest.approx(1.0 - expected.metrics[-1]['mean_cue_fraction'], abs=1e-12)


def test_beeclust_through_the_vector_env_is_the_batched_engine():
    config = SMALL.replace(episode={'duration': 10.0})
    env = MonaSwarmVectorEnv(3, config)
    observed, _ = env.reset(seed=11)
    assert observed.shape == (3, 8, 12) and env.observation_space.contains(observed)
    parts = []
    for k in range(3):
        part = make_controller(config.controller, config.mona, range(8))
        part.reset(11 + k)
        parts.append(part)
    merged = type(parts[0]).merge(parts)
    truncated = np.zeros(3, dtype=bool)
    while not truncated.any():
        ground, ranges, is_robot = env.batch.sense()
        now = np.repeat([e.world.time_ns / 1e9 for e in env.episodes], 8)
        command = merged.step(ground, ranges, is_robot, now)
        actions = np.column_stack([command.wheels, command.cleaner]).reshape(3, 8, 3)
        _, rewards, terminated, truncated, _ = env.step(actions)
        assert not terminated.any() and rewards.shape == (3,)
    assert truncated.all()
    expected = run_batch([config.replace(episode={'seed': 11 + k}) for k in range(3)])
    for k in range(3):
        assert env.metrics[k] == expected[k].metrics
    # Next-step autoreset: the following step starts the next seeds and ignores the actions.
    observed, rewards, _, truncated, _ = env.step(np.zeros((3, 8, 3)))
    assert not truncated.any() and not rewards.any()
    assert [e.seed for e in env.episodes] == [14, 15, 16]
    lone = MonaSwarmParallelEnv(config)
    first, _ = lone.reset(seed=14)
    assert np.array_equal(observed[0], np.stack([first[a] for a in lone.possible_agents]))


def test_observations_and_actions_are_what_the_docs_say():
    mona = SMALL.mona
    ground = np.array([[0, 255]], dtype=np.uint8)
    ranges = np.array([[np.inf, 0.0, mona.ir_range / 2, mona.ir_range, 0.001]],
                      dtype=np.float32)
    robots = np.array([[False, True, False, True, False]])
    row = observations(ground, ranges, robots, mona)[0]
    assert row[:2].tolist() == [0.0, 1.0]
    assert row[2:7] == pytest.approx([0.0, 1.0, 0.5, 0.0, 1 - 0.001 / mona.ir_range], abs=1e-6)
    assert row[7:].tolist() == [0.0, 1.0, 0.0, 1.0, 0.0]
    command = commands_from_actions(np.array([[12.0, -3.0, 0.7], [1.0, 2.0, 0.2]]), mona)
    assert command.wheels.tolist() == [[10.0, -3.0], [1.0, 2.0]]
    assert command.cleaner.tolist() == [True, False]
    with pytest.raises(EnvError, match=r'actions must be \[N, 3\]'):
        commands_from_actions(np.zeros((2, 2)), mona)
    with pytest.raises(EnvError, match='finite'):
        commands_from_actions(np.array([[np.nan, 0.0, 0.0]]), mona)


def test_misuse_is_refused_with_a_clear_error():
    env = MonaSwarmParallelEnv(SMALL)
    with pytest.raises(EnvError, match='call reset'):
        env.step({})
    env.reset(seed=1)
    with pytest.raises(EnvError, match='no action for mona_0, mona_1, mona_2 and 5 more'):
        env.step({})
    vector = MonaSwarmVectorEnv(2, SMALL)
    with pytest.raises(EnvError, match='call reset'):
        vector.step(np.zeros((2, 8, 3)))
    vector.reset()
    with pytest.raises(EnvError, match=r'shape \(2, 8, 3\)'):
        vector.step(np.zeros((2, 3)))
    with pytest.raises(EnvError, match='num_envs'):
        MonaSwarmVectorEnv(0, SMALL)


def _poses_after_resets(env, first_seed: int | None, resets: int) -> list[bytes]:
    env.reset(seed=first_seed)
    seen = [env.state().tobytes()]
    for _ in range(resets):
        env.reset()
        seen.append(env.state().tobytes())
    return seen


def test_an_unseeded_reset_starts_a_fresh_episode_and_the_first_seed_fixes_the_sequence():
    # Gymnasium's Env.reset: with seed=None the generator goes on, it is not reset.
    config = SMALL.replace(episode={'population': 6})
    first = _poses_after_resets(MonaSwarmParallelEnv(config), 7, 3)
    assert len(set(first)) == 4  # four resets, four episodes
    assert _poses_after_resets(MonaSwarmParallelEnv(config), 7, 3) == first
    lone = MonaSwarmParallelEnv(config)
    lone.reset(seed=9)  # the sequence is the seeds after the first: 7, 8, 9, ...
    assert lone.state().tobytes() == first[2]
    fresh = MonaSwarmParallelEnv(config)
    fresh.reset()  # never seeded: from the config's episode.seed
    assert fresh.episode.seed == config.episode.seed
    vector = MonaSwarmVectorEnv(2, config)
    vector.reset(seed=20)
    assert [episode.seed for episode in vector.episodes] == [20, 21]
    vector.reset()
    assert [episode.seed for episode in vector.episodes] == [22, 23]
    vector.reset(seed=20)
    assert [episode.seed for episode in vector.episodes] == [20, 21]


def test_render_gives_the_video_frame_of_the_state_with_its_obstacles():
    config = SMALL.replace(episode={'population': 4, 'duration': 1.0},
                           world={'obstacles': {'box': [0.3, 0.3, 0.9, 0.9]}})
    env = MonaSwarmParallelEnv(config, render_mode='rgb_array')
    assert 'rgb_array' in env.metadata['render_modes']
    env.reset(seed=2)
    before = env.render()
    # PettingZoo's render_test demands this of an 'rgb_array' frame.
    assert isinstance(before, np.ndarray) and before.ndim == 3 and before.shape[2] == 3
    assert before.dtype == np.uint8
    bare = MonaSwarmParallelEnv(SMALL.replace(episode={'population': 4, 'duration': 1.0}),
                                render_mode='rgb_array')
    bare.reset(seed=2)
    filled = [np.all(frame == OBSTACLE_FILL, axis=2).sum() for frame in (before, bare.render())]
    # The obstacle, a grey square on the map (the text's anti-aliasing has a few such pixels).
    assert filled[0] - filled[1] > 1000 and filled[1] < 100, filled
    env.step({agent: np.array([0.0, 0.0, 1.0]) for agent in env.agents})  # all cleaning
    after = env.render()
    assert after.shape == before.shape and not np.array_equal(after, before)
    vector = MonaSwarmVectorEnv(2, config, render_mode='rgb_array')
    vector.reset(seed=2)
    frames = vector.render()
    assert len(frames) == 2 and np.array_equal(frames[0], before)
    with pytest.raises(EnvError, match="render_mode = 'human' is not supported"):
        MonaSwarmParallelEnv(config, render_mode='human')
    with pytest.warns(UserWarning, match='without specifying any render mode'):
        assert MonaSwarmParallelEnv(config).render() is None
