"""The three executables as real processes, started with the command lines of
docs/interfaces.md: a short lockstep run ends with every process exiting 0."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.ros

BIN = Path(sys.executable).parent
CONFIG = Path(__file__).resolve().parents[2] / 'ros_ws' / 'config' / 'mona_swarm.yaml'
PARAMS = ['--ros-args', '--params-file', str(CONFIG)]


def test_world_controllers_and_supervisor_run_an_episode_and_exit_cleanly(processes,
                                                                          tmp_path):
    out = tmp_path / 'out'
    world = processes.spawn([str(BIN / 'world_node'), *PARAMS, '-p', f'output_dir:={out}'],
                            'world')
    # Robots 0 and 1 share a process, robot 2 has its own.
    shared = processes.spawn([str(BIN / 'mona_controller_node'), '--robots', '0-1', *PARAMS],
                             'controllers')
    alone = processes.spawn([str(BIN / 'mona_controller_node'), *PARAMS, '-r',
                             '__ns:=/mona_2'], 'controller_2')
    supervisor = processes.spawn(
        [str(BIN / 'supervisor_node'), *PARAMS, '-p', 'episode.population:=3', '-p',
         'episode.duration:=1.0', '-p', 'episodes:=2', '-p', f'output_dir:={out}'],
        'supervisor')
    for process in (supervisor, world, shared, alone):
        assert process.wait(180) == 0, processes.log(process.name)

    record = json.loads((out / 'run.json').read_text())
    assert [e['seed'] for e in record['episodes']] == [1, 2]
    for k in (0, 1):
        final = np.load(out / f'episode_{k}' / 'world_final.npz')
        assert final['poses'].shape == (3, 3) and int(final['steps']) == 32
    assert 'robot 2 connected to a world' in processes.log('controller_2')
