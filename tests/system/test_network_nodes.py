"""The node system with the network controller: scripts/swarm.sh --config with
``controller.kind: network`` runs one controller process per Mona, each loading the same
weights file, and the lockstep episode equals the embedded runner's bit for bit (N = 5,
20 s: 625 steps; 60 s, as before, met no encounter either, so took no other path), as for
BEECLUST (tests/system/test_system.py); also with the fair match's limits
(controller.network.max_speed, clean_stops) and the weights named relative to the
parameter file (the launcher hands the nodes the resolved path)."""

from __future__ import annotations

import numpy as np
import pytest

from mona_controller.controllers.network_weights import (
    genome_size,
    save_weights,
    weights_from_genome,
)
from swarm_supervisor.config import load_config, write_ros_yaml
from swarm_supervisor.engine.runner import run_episode

from swarmrun import CONFIG, SwarmRun

pytestmark = [pytest.mark.ros, pytest.mark.slow]

POPULATION, DURATION, SEED, HIDDEN = 5, 20.0, 7, 6


@pytest.mark.parametrize('fair', [False, True])
def test_network_controllers_as_nodes_equal_the_embedded_runner(tmp_path, fair):
    ir_count = load_config(CONFIG).mona.ir_count
    genome = np.random.default_rng(5).normal(0.0, 0.8, genome_size(ir_count, HIDDEN, True))
    weights = tmp_path / 'net.npz'
    save_weights(weights, weights_from_genome(genome, ir_count, HIDDEN, True))
    config = load_config(CONFIG).replace(
        episode={'population': POPULATION, 'duration': DURATION, 'seed': SEED},
        controller={'kind': 'network', 'network': {
            'hidden': HIDDEN, 'recurrent': True, 'weights': str(weights),
            # fair: wheels capped at 8 cm/s, no wheels while cleaning
            'max_speed': 0.08 if fair else 0.0, 'clean_stops': fair}})
    path = tmp_path / 'network.yaml'
    write_ros_yaml(config, path)
    if fair:  # also: the weights named relative to the parameter file, not to the cwd
        path.write_text(path.read_text().replace(str(weights), weights.name))
        assert f'weights: {weights.name}' in path.read_text()
        assert load_config(path) == config
    run = SwarmRun(tmp_path / 'run', ['--config', str(path), '--population', str(POPULATION),
                                      '--duration', str(DURATION), '--seed', str(SEED),
                                      '--mode', 'lockstep'])
    try:
        status = run.wait()
    finally:
        run.stop()
    assert status == 0, run.stderr
    assert {f'controller_{i}' for i in range(POPULATION)} <= set(run.nodes())
    final = np.load(run.out / 'episode_0' / 'world_final.npz')
    embedded = run_episode(config)
    assert int(final['steps']) == embedded.steps
    np.testing.assert_array_equal(final['poses'], embedded.final_poses)
    np.testing.assert_array_equal(final['cue'], embedded.final_cue.astype(np.float32))
    assert not np.allclose(embedded.final_poses, embedded.initial_poses)
