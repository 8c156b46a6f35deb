"""The batched engine: each episode of a batch is byte for byte the episode run alone."""

import numpy as np
import pytest

from mona_controller.controllers.beeclust import SwarmController
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.batch import Batch, BatchError
from swarm_supervisor.engine.episode import Episode
from swarm_supervisor.engine.runner import run_batch, run_episode
from swarm_supervisor.outputs.episode_folder import write_episode

SNAPSHOTS = (0.0, 7.0, 20.0)


def mix() -> list[SwarmConfig]:
    """Different populations, seeds, speeds, durations, noise, gains and wall behaviour."""
    base = SwarmConfig().replace(episode={'duration': 30.0})
    return [
        base.replace(episode={'population': 5, 'seed': 3}, controller={'speed': 0.04}),
        base.replace(episode={'population': 10, 'seed': 1},
                     mona={'ground_noise': 4.0, 'ir_miss': 0.2, 'wheel_noise': 0.1}),
        base.replace(episode={'population': 20, 'seed': 2, 'duration': 22.0},
                     controller={'beeclust': {'alpha': 3.0, 'wait_max': 20.0,
                                              'avoid': 'random-turn'}}),
        base.replace(episode={'population': 20, 'seed': 7},
                     mona={'ir_range': 0.05, 'ground_footprint': 0.03}),
        base.replace(episode={'population': 8, 'seed': 5},
                     mona={'ground_transfer': 'webots', 'ground_offset': 0.03,
                           'ground_baseline': 0.05, 'ground_noise': 2.0,
                           'robot_detection': 'position', 'ir_robot_factor': 0.5}),
        base.replace(episode={'population': 12, 'seed': 6},
                     world={'cleaning': 'blend', 'cell_size': 0.00390625},
                     controller={'beeclust': {'turn_at': 'full', 'wait_max': 5.0}}),
    ]


def files(result, folder) -> dict[str, bytes]:
    """The bytes of the outputs that must match (episode.json holds timing)."""
    write_episode(result, folder)
    return {name: (folder / name).read_bytes()
            for name in ('metrics.csv', 'snapshots.npz', 'final_cue_map.png')}


def test_batched_episodes_equal_lone_episodes_in_any_order(tmp_path):
    configs = mix()
    alone = [run_episode(c, snapshot_times=SNAPSHOTS) for c in configs]
    forward = run_batch(configs, snapshot_times=SNAPSHOTS)
    order = [2, 4, 0, 5, 3, 1]
    backward = run_batch([configs[k] for k in order], snapshot_times=SNAPSHOTS)
    backward = [backward[order.index(k)] for k in range(len(configs))]
    assert sum(r.encounters for r in alone) > 0
    for k, lone in enumerate(alone):
        for batched in (forward[k], backward[k]):
            assert batched.config == lone.config
            assert batched.metrics == lone.metrics
            assert batched.steps == lone.steps
            assert batched.encounters == lone.encounters
            for name in ('initial_poses', 'final_poses', 'final_cue'):
                assert np.array_equal(getattr(batched, name), getattr(lone, name)), name
            assert batched.snapshots.keys() == lone.snapshots.keys()
            for t, (cue, poses) in lone.snapshots.items():
                assert np.array_equal(batched.snapshots[t][0], cue)
                assert np.array_equal(batched.snapshots[t][1], poses)
    # ... and through the real writers, the same bytes.
    for k in (1, 2):
        assert files(alone[k], tmp_path / f'alone{k}') == files(forward[k], tmp_path / f'b{k}')


def test_batched_sensing_equals_world_sense_with_noise():
    configs = mix()
    episodes = [Episode(c) for c in configs]
    lone = [Episode(c) for c in configs]
    batch = Batch(episodes)
    for _ in range(40):
        for batched, alone in zip(batch.readings(), lone):
            expected = alone.world.sense()
            assert batched.time_ns == expected.time_ns
            assert np.array_equal(batched.ground, expected.ground)
            assert np.array_equal(batched.ranges, expected.ranges)
            assert np.array_equal(batched.is_robot, expected.is_robot)
        batch.step()
        for alone in lone:
            alone.step()


def test_a_finished_episode_leaves_and_the_rest_go_on():
    configs = mix()
    finished = []
    results = run_batch(configs, finished=lambda k, r: finished.append(k))
    assert finished[0] == 2  # the shortest (22 s) ends first and is handed over at once
    assert sorted(finished) == list(range(len(configs)))
    assert [r.steps for r in results] == [c.steps() for c in configs]


def test_merged_controller_keeps_the_parts_views():
    base = SwarmConfig()
    parts = [SwarmController(base.controller, base.mona, range(n)) for n in (3, 4)]
    merged = SwarmController.merge(parts)
    merged.state[:] = 2
    merged.encounters[5] = 9
    assert parts[0].state.tolist() == [2, 2, 2] and parts[1].encounters[2] == 9


def test_episodes_that_step_differently_are_refused():
    base = SwarmConfig()
    with pytest.raises(BatchError, match='step and control periods'):
        Batch([Episode(base.replace(episode={'population': 3})),
               Episode(base.replace(episode={'population': 3}, world={'step_period': 0.05}))])
    with pytest.raises(BatchError, match=r"\(32000000, 1, 5, 'beeclust'\), \(32000000, 2, 5"):
        Batch([Episode(base.replace(episode={'population': 3})),
               Episode(base.replace(episode={'population': 3}, world={'control_steps': 2}))])
