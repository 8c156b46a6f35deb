"""The control period (``world.control_steps``): the controllers answer every k-th step and the
wheels hold between; k = 1 is the engine as it always was, and a batch equals each episode."""

import numpy as np

from mona_controller.controllers.beeclust import SwarmController
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine import Episode, run_batch, run_episode


def config(k: int, **episode) -> SwarmConfig:
    return SwarmConfig().replace(episode={'population': 12, 'seed': 4, 'duration': 40.0,
                                          **episode}, world={'control_steps': k})


def test_commands_change_only_at_every_kth_step(monkeypatch):
    episode = Episode(config(3))
    asked = []  # the step at which each answer was asked for
    answer = SwarmController.step

    def step(self, *args):
        asked.append(episode.steps_done)
        return answer(self, *args)

    monkeypatch.setattr(SwarmController, 'step', step)
    commands = [episode.step().command for _ in range(30)]
    assert asked == list(range(0, 30, 3))  # at steps 0, 3, 6, ... only
    for j in range(30):
        assert commands[j] is commands[j - j % 3]  # the wheels and the cleaner hold it


def test_one_step_per_control_step_is_the_engine_as_it_was():
    # The golden digests pin k = 1 byte for byte; here k = 1 and k = 2 also differ.
    one, two = run_episode(config(1)), run_episode(config(2))
    assert one.metrics != two.metrics
    assert not np.array_equal(one.final_poses, two.final_poses)


def test_a_batch_with_a_control_period_equals_each_episode_alone():
    configs = [config(4), config(4, population=5, seed=9, duration=31.0),
               config(4, population=20, seed=2)]
    times = (0.0, 10.0, 31.0)
    alone = [run_episode(c, snapshot_times=times) for c in configs]
    batched = run_batch(configs, snapshot_times=times)
    for lone, member in zip(alone, batched):
        assert member.metrics == lone.metrics
        assert member.encounters == lone.encounters
        assert np.array_equal(member.final_poses, lone.final_poses)
        assert np.array_equal(member.final_cue, lone.final_cue)
    assert sum(r.encounters for r in alone) > 0
