"""The runnable recipes of docs/extending.md (examples/) work as the page says."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mona_controller.controllers import states_of
from mona_controller.schema import ParameterError
from swarm_supervisor.cli import command, main
from swarm_supervisor.config import load_config
from swarm_supervisor.engine import run_batch, run_episode

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))  # the examples are imported as the package `examples`

from examples import solitary_cleaner  # noqa: E402


def test_a_controller_of_ones_own_runs_alone_and_in_a_batch():
    solitary_cleaner.register()
    base = load_config().replace(episode={'population': 20, 'duration': 60.0, 'seed': 3},
                                 controller={'kind': 'solitary'})
    alone = run_episode(base)
    assert alone.metrics[-1]['mean_cue_fraction'] < 1.0  # it cleans
    beeclust = run_episode(base.replace(controller={'kind': 'beeclust'}))
    assert not np.array_equal(alone.final_poses, beeclust.final_poses)
    # Its own parameter changes what it does; merged with other episodes of its kind (other
    # parameters of its own and of BEECLUST's) it computes what it computes alone.
    other = base.replace(episode={'population': 7, 'seed': 8},
                         controller={'solitary': {'clean_above': 60.0, 'cooldown': 2.0},
                                     'beeclust': {'alpha': 5.0}})
    assert other.controller.solitary.clean_above == 60.0
    assert not np.array_equal(
        run_episode(base.replace(controller={'solitary': {'clean_above': 60.0}})).final_poses,
        alone.final_poses)
    batched = run_batch([base, other])
    assert batched[0].metrics == alone.metrics
    assert np.array_equal(batched[0].final_poses, alone.final_poses)


def test_a_controller_of_ones_own_declares_its_parameters_and_states(tmp_path):
    solitary_cleaner.register()
    path = tmp_path / 'solitary.yaml'
    path.write_text('/**:\n  ros__parameters:\n    controller:\n      kind: solitary\n'
                    '      solitary: {clean_above: 80, cooldown: 5.0}\n')
    config = load_config(path)
    assert (config.controller.solitary.clean_above, config.controller.solitary.cooldown) == (
        80.0, 5.0)
    assert config.value('controller.solitary.cooldown') == 5.0
    with pytest.raises(ParameterError, match='unknown parameter controller.solitary.gain; '
                                             'known in controller.solitary.: clean_above, '
                                             'cooldown'):
        config.replace(controller={'solitary': {'gain': 1.0}})
    with pytest.raises(ParameterError, match=r'controller.solitary.cooldown = -1.0 is out of '
                                             r'range: allowed \[0, 3600\] s'):
        config.with_values({'controller.solitary.cooldown': -1.0})
    # Observers take the names and colours from the kind: the states it declares.
    assert [state.name for state in states_of('solitary')] == ['roam', 'clean', 'dodge']
    assert solitary_cleaner.SolitaryCleaner.STATES[solitary_cleaner.CLEAN].colour == (
        0.90, 0.10, 0.10, 1.0)


def test_an_unknown_kind_is_refused_naming_the_known_ones():
    with pytest.raises(Exception, match="controller.kind = 'nope' is not allowed: one of "
                                        "'beeclust'"):
        load_config().replace(controller={'kind': 'nope'})


def test_the_controller_example_runs_as_a_script():
    done = subprocess.run([sys.executable, str(ROOT / 'examples' / 'solitary_cleaner.py')],
                          capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert 'beeclust:' in done.stdout and 'solitary:' in done.stdout
    assert ' follow' in done.stdout and ' roam' in done.stdout  # each kind's own states


def test_a_subcommand_of_ones_own(tmp_path, capsys, monkeypatch):
    out = tmp_path / 'run'
    assert main(['run', '--population', '4', '--duration', '5', '--out', str(out)]) == 0
    monkeypatch.setitem(command.COMMAND_MODULES, 'examples.summary_command', ('summary',))
    capsys.readouterr()
    assert main(['summary', str(tmp_path)]) == 0
    assert 'run: N = 4, 8 cm/s, seed 1:' in capsys.readouterr().out
    assert main(['summary', str(tmp_path / 'nothing')]) == 2
    assert 'does not exist' in capsys.readouterr().err


def test_an_obstacle_layout_of_ones_own_runs_and_keeps_robots_out(tmp_path):
    layout = ROOT / 'examples' / 'obstacle_layout.yaml'
    config = load_config(layout)
    arena = config.world.arena()
    assert len(arena.obstacles) == 8
    out = tmp_path / 'ring'
    assert main(['run', '--config', str(layout), '--population', '20', '--duration', '30',
                 '--out', str(out)]) == 0
    final = np.load(out / 'snapshots.npz')['final_poses']
    # Every robot's centre at least its radius from every obstacle (less the collision slop
    # and one step's travel, see tests/unit/test_arena.py).
    assert min(arena.clearance(x, y) for x, y in final[:, :2]) > 0.04 - 0.0048


def test_a_metric_of_ones_own_reaches_the_csv_and_the_bag(tmp_path):
    out = tmp_path / 'mine'
    env = dict(os.environ, PYTHONPATH=str(ROOT), MONA_SWARM_METRICS='examples.cue_under_robots')
    done = subprocess.run([str(Path(sys.executable).with_name('mona-swarm')), 'run',
                           '--population', '6', '--duration', '20', '--out', str(out),
                           '--bag'], capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stderr
    header, *rows = (out / 'metrics.csv').read_text().splitlines()
    assert header.split(',')[-1] == 'cue_under_robots'
    values = [float(row.split(',')[-1]) for row in rows]
    assert len(values) == 21 and all(0.0 <= v <= 255.0 for v in values)
    # The bag carries its topic too (the run checks the bag's online samples equal the rows).
    assert b'/metrics/cue_under_robots' in (out / 'bag' / 'bag.mcap').read_bytes()


def test_the_metric_example_runs_as_a_script():
    done = subprocess.run([sys.executable, str(ROOT / 'examples' / 'cue_under_robots.py')],
                          capture_output=True, text=True, timeout=300, cwd=ROOT,
                          env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert done.returncode == 0, done.stderr
    assert 'under the robots' in done.stdout
