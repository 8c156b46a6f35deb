"""``mona-swarm heldout``: controllers on the same held-out seeds, paired tests with Holm's
adjustment, effect sizes, the behaviour table and the figure; resumable; a bad plan is
refused with exit 2 naming the key."""

import json
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import yaml

from swarm_supervisor.evolution.heldout import episode_config, load_plan, read_chunk
from swarm_supervisor.evolution.heldout_stats import holm, paired, rank_biserial

SEEDS = [4_300_000_001, 4_300_000_002, 4_300_000_003, 4_300_000_004, 4_300_000_005,
         4_300_000_006]


def write_plan(folder, **changes):
    (folder / 'seeds.yaml').write_text(yaml.safe_dump({'seeds': SEEDS}))
    plan = {'seeds': 'seeds.yaml', 'robots': 8, 'duration': 8.0, 'batch': 4,
            'behaviour_seeds': 1,
            'scenarios': {'alone': {'config': str(_shipped())},
                          'pairs': {'config': str(_shipped()),
                                    'world': {'cleaning_quorum': 2}}},
            'controllers': {'fast': {}, 'slow': {'controller': {'speed': 0.04}}},
            'pairs': [['slow', 'fast']], 'figure': ['alone', 'pairs'], **changes}
    path = folder / 'plan.yaml'
    path.write_text(yaml.safe_dump({'heldout': plan}))
    return path


def _shipped():
    from pathlib import Path

    return Path(__file__).resolve().parents[2] / 'ros_ws' / 'config' / 'mona_swarm.yaml'


def command(plan, out, *extra):
    return [sys.executable, '-m', 'swarm_supervisor.cli', 'heldout', str(plan), '--out',
            str(out), *extra]


def test_a_comparison_pairs_the_seeds_adjusts_p_and_resumes(tmp_path):
    plan_path = write_plan(tmp_path)
    plan = load_plan(plan_path)
    config = episode_config(plan, 'pairs', 'slow', SEEDS[2])
    assert (config.world.cleaning_quorum, config.controller.speed) == (2, 0.04)
    assert (config.episode.population, config.episode.seed) == (8, SEEDS[2])
    out = tmp_path / 'out'
    ran = subprocess.run(command(plan_path, out, '--jobs', '2'), capture_output=True,
                         text=True, timeout=900)
    assert ran.returncode == 0, ran.stderr
    chunk = read_chunk(out, 'alone', 'slow')
    assert chunk is not None and chunk['seed'] == [float(s) for s in SEEDS]
    summary = json.loads((out / 'summary.json').read_text())
    tests = [t for scenario in summary.values() for pair in scenario['pairs'].values()
             for t in pair.values()]
    assert len(tests) == 4  # two scenarios, two scores
    for test in tests:
        assert test['seeds'] == 6 and test['p_holm'] >= test['p_value']
    assert max(t['p_holm'] for t in tests) == pytest.approx(
        max(holm([t['p_value'] for t in tests])))
    behaviour = json.loads((out / 'behaviour.json').read_text())
    assert set(behaviour) == {f'{s}.{c}' for s in ('alone', 'pairs') for c in ('fast', 'slow')}
    assert behaviour['alone.slow']['forward_speed'] < behaviour['alone.fast']['forward_speed']
    assert 0 <= behaviour['pairs.fast']['removed_per_tick'] < \
        behaviour['alone.fast']['removed_per_tick'] <= 1
    assert (out / 'cue_vs_k.png').stat().st_size > 0
    assert '| alone | slow vs fast | fitness |' in (out / 'report.md').read_text()
    # A chunk lost is run again, and comes back byte for byte; the others are not rerun.
    kept = (out / 'scores' / 'alone.fast.csv').stat().st_mtime_ns
    lost = (out / 'scores' / 'pairs.slow.csv').read_bytes()
    (out / 'scores' / 'pairs.slow.csv').unlink()
    # The same command again, in this process (the first run was a process of its own).
    from swarm_supervisor.cli import main
    assert main(command(plan_path, out, '--no-behaviour')[3:]) == 0
    assert (out / 'scores' / 'pairs.slow.csv').read_bytes() == lost
    assert (out / 'scores' / 'alone.fast.csv').stat().st_mtime_ns == kept


def test_sigterm_keeps_the_chunks_written_and_the_same_command_resumes(tmp_path):
    plan_path = write_plan(tmp_path)
    out = tmp_path / 'out'
    process = subprocess.Popen(command(plan_path, out, '--no-behaviour'),
                               stderr=subprocess.PIPE, text=True)
    first = out / 'scores' / 'alone.fast.csv'
    deadline = time.monotonic() + 300
    while not first.exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert process.poll() is None, 'it ended before it could be stopped'
    process.send_signal(signal.SIGTERM)  # three chunks still to run
    _, err = process.communicate(timeout=120)
    assert process.returncode == 143, err
    assert 'interrupted: the scores written are kept' in err and 'Traceback' not in err
    kept = sorted(p.name for p in (out / 'scores').glob('*.csv'))
    assert 'alone.fast.csv' in kept and len(kept) < 4 and not (out / 'summary.json').exists()
    resumed = subprocess.run(command(plan_path, out, '--no-behaviour'), capture_output=True,
                             text=True, timeout=900)
    assert resumed.returncode == 0, resumed.stderr
    assert len(list((out / 'scores').glob('*.csv'))) == 4 and (out / 'summary.json').exists()


@pytest.mark.parametrize(('changes', 'message'), [
    ({'robot': 3}, 'unknown key heldout.robot'),
    ({'pairs': [['slow', 'nobody']]}, r"heldout.pairs: \['slow', 'nobody'\] is not two"),
    ({'controllers': {'bad': {'controller': {'speed': 9.0}}}},
     'scenario alone with controller bad: controller.speed'),
    ({'scenarios': {'x': {'world': {}}}}, 'heldout.scenarios.x.config is missing'),
    ({'duration': -1.0}, r'heldout.duration = -1.0 must be > 0'),
    ({'seeds': 'missing.yaml'}, 'heldout.seeds'),
])
def test_a_bad_plan_is_refused_with_exit_2_naming_the_key(tmp_path, changes, message):
    if 'controllers' in changes or 'pairs' in changes:
        changes.setdefault('pairs', [])
    plan = write_plan(tmp_path, **changes)
    result = subprocess.run(command(plan, tmp_path / 'out'), capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 2, result.stderr
    assert __import__('re').search(message, result.stderr), result.stderr
    assert not (tmp_path / 'out').exists()


def test_the_effect_size_and_the_adjustment_by_hand():
    a, b = [1.0, 2.0, 3.0, 4.0], [2.0, 3.0, 5.0, 4.0]
    assert rank_biserial(a, b) == -1.0  # lower on every seed that differs
    assert rank_biserial(b, a) == 1.0
    # differences +1, -2, +3 (ranks 1, 2, 3): (1 + 3 - 2) / 6
    assert rank_biserial([2.0, 1.0, 6.0], [1.0, 3.0, 3.0]) == pytest.approx(2 / 6)
    assert holm([0.01, 0.04, 0.03]) == pytest.approx([0.03, 0.06, 0.06])
    result = paired(list(np.arange(10.0)), list(np.arange(10.0) + 1.0))
    assert result['a_lower'] == 10 and result['median_difference'] == -1.0
    assert result['p_value'] < 0.01
