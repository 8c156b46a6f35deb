"""``mona-swarm calibrate`` on a tiny design: it runs, an interrupted search resumes with no
trial lost or repeated and equals an uninterrupted one, the seed reproduces the trials, and a
bad design is refused naming the key."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import optuna
import pandas as pd
import pytest
import yaml

from swarm_supervisor.calibration import PAPER_RATIO, CalibrationError, load_design
from swarm_supervisor.cli import main
from swarm_supervisor.config import load_config

TINY = {
    'seed': 3, 'trials': 4, 'batch': 2, 'startup': 2,
    'screen': {'populations': [3, 6], 'speeds': [0.04, 0.08], 'seeds': [1, 2],
               'duration': 10.0, 'snapshot_times': [10.0]},
    'confirm': {'candidates': 1},
    'parameters': {'controller.beeclust.alpha': {'low': 1.0, 'high': 20.0, 'log': True},
                   'controller.beeclust.avoid': {'choices': ['turn-away', 'random-turn']},
                   'world.step_period': {'low': 0.02, 'high': 0.05}},
}


def write_design(folder: Path, **changes) -> Path:
    body = {**TINY, **changes}
    # The confirmation study: the screening's with three seeds.
    body.setdefault('confirm', {})
    body['confirm'] = {**body['confirm'], 'study': {**body['screen'], 'seeds': [1, 2, 3]}}
    path = folder / 'tiny.yaml'
    path.write_text(yaml.safe_dump({'calibrate': body}))
    return path


def calibrate(design: Path, out: Path) -> int:
    """The command, its episodes on one worker process (a pool is started for each batch
    of trials, and starting workers is most of what a tiny search costs)."""
    return main(['calibrate', str(design), '--out', str(out), '--jobs', '1'])


def trials(out: Path) -> pd.DataFrame:
    return pd.read_csv(out / 'trials.csv')


@pytest.fixture(scope='module')
def searched(tmp_path_factory) -> Path:
    """The tiny design's whole search, never interrupted (4 trials, one confirmed): the first
    test looks at it, and the interrupted and the extended searches are compared with it."""
    folder = tmp_path_factory.mktemp('whole')
    assert calibrate(write_design(folder), folder / 'out') == 0
    return folder / 'out'


def test_a_search_runs_scores_confirms_and_writes_a_profile(searched):
    out = searched
    table = trials(out)
    assert list(table['trial']) == [0, 1, 2, 3]
    assert (table['claims'] == 13).all()
    # The loss is the failed claims plus a decade of the ratio per unit of weight.
    decades = [min(abs(math.log10(r / PAPER_RATIO)), 3.0) if r > 0 else 3.0
               for r in table['ratio']]
    assert table['loss'].tolist() == pytest.approx(
        [13 - held + d for held, d in zip(table['claims_held'], decades)])
    assert (out / 'trials' / '0000' / 'all_metrics.csv').exists()
    assert not (out / 'trials' / '0000' / 'episodes').exists()  # only the table is kept
    confirmed = list((out / 'confirm').iterdir())
    assert len(confirmed) == 1 and (confirmed[0] / 'report.md').exists()
    # The profile is a parameter file with the best trial's values.
    profile = load_config(out / 'best_profile.yaml')
    best = int(confirmed[0].name.split('_')[1])
    row = table[table['trial'] == best].iloc[0]
    assert profile.controller.beeclust.alpha == row['controller.beeclust.alpha']
    assert profile.controller.beeclust.avoid == row['controller.beeclust.avoid']
    assert profile.world.step_period == row['world.step_period']
    report = (out / 'calibration.md').read_text()
    assert 'The best profile' in report and 'Existence search' not in report
    assert not (out / 'best_trial.yaml').exists()
    # Each claim's tally is the number of trials whose failed claims do not name it.
    failed = [str(names).split() for names in table['failed'].fillna('')]
    for claim in ('fig4-more-robots-8cm', 'table2-factor-order'):
        held = sum(claim not in names for names in failed)
        assert f'| `{claim}` | {held} | 4 |' in report


def test_an_existence_search_is_labelled_and_writes_no_profile(tmp_path):
    design = write_design(tmp_path, purpose='existence', trials=2, startup=2,
                          confirm={'candidates': 0})
    out = tmp_path / 'out'
    assert calibrate(design, out) == 0
    report = (out / 'calibration.md').read_text()
    assert report.startswith('# Existence search: tiny.yaml')
    assert 'An existence search, not a profile' in report and '## The best trial' in report
    assert not (out / 'best_profile.yaml').exists()
    best = (out / 'best_trial.yaml').read_text()
    assert best.startswith('# The best trial of the existence search (not a profile')
    row = trials(out).sort_values(['loss', 'trial']).iloc[0]
    best = load_config(out / 'best_trial.yaml')
    assert best.controller.beeclust.alpha == row['controller.beeclust.alpha']


def test_an_interrupted_search_resumes_and_equals_an_uninterrupted_one(tmp_path, searched):
    # Nothing confirmed: the screening is what is resumed (``searched`` confirms one
    # candidate, its best screened trial, so its profile holds that trial's values too).
    design = write_design(tmp_path, confirm={'candidates': 0})
    broken = tmp_path / 'broken'
    process = subprocess.Popen(
        [sys.executable, '-m', 'swarm_supervisor.cli', 'calibrate', str(design), '--out',
         str(broken), '--jobs', '1'], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True)
    # Ctrl-C as trial 0 is scored: amid optuna's bookkeeping, where the signal can land in a
    # weakref callback that swallows the exception (the search ran on to its end in 2 of 3
    # tries before it checked for a signal between trials).
    first = broken / 'trials' / '0000' / 'trial.json'
    deadline = time.monotonic() + 120
    while not first.exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert process.poll() is None, 'the search ended before it could be interrupted'
    os.killpg(process.pid, signal.SIGINT)  # Ctrl-C: the whole foreground group
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert 'rerun the same command to resume' in err
    storage = f'sqlite:///{broken / "calibration.db"}'
    asked = optuna.load_study(study_name='calibration', storage=storage).get_trials()
    assert len(asked) < 4 or any(t.state.name == 'RUNNING' for t in asked)
    # Resume to the end; the same screening's uninterrupted search is ``searched``.
    assert calibrate(design, broken) == 0
    whole = searched
    done = optuna.load_study(study_name='calibration', storage=storage).get_trials()
    assert [t.number for t in done] == [0, 1, 2, 3]  # none lost, none asked twice
    assert all(t.state.name == 'COMPLETE' for t in done)
    pd.testing.assert_frame_equal(trials(broken), trials(whole))
    assert (broken / 'best_profile.yaml').read_text().splitlines()[2:] == \
        (whole / 'best_profile.yaml').read_text().splitlines()[2:]


def test_raising_or_lowering_trials_carries_on_or_stops_in_the_same_folder(tmp_path, searched):
    out = tmp_path / 'out'
    assert calibrate(write_design(tmp_path, trials=2, confirm={'candidates': 0}), out) == 0
    assert list(trials(out)['trial']) == [0, 1]
    # Raised: the same folder carries on, and the trials are an uninterrupted search's.
    raised = write_design(tmp_path, trials=4, confirm={'candidates': 0})
    assert calibrate(raised, out) == 0
    # An uninterrupted search of 4 trials (what is confirmed afterwards changes no trial).
    pd.testing.assert_frame_equal(trials(out), trials(searched))
    # Lowered: the report covers the trials asked for, and confirms among them only.
    lowered = write_design(tmp_path, trials=3, confirm={'candidates': 1})
    assert calibrate(lowered, out) == 0
    pd.testing.assert_frame_equal(trials(out), trials(searched).iloc[:3])
    assert '3 trials of the screening study' in (out / 'calibration.md').read_text()
    best = trials(out).sort_values(['loss', 'trial']).iloc[0]
    assert [f.name for f in (out / 'confirm').iterdir()] == [f'trial_{best["trial"]:04d}']


def test_another_seed_proposes_other_trials_and_a_folder_keeps_its_design(tmp_path):
    a = load_design(write_design(tmp_path))
    other = tmp_path / 'other'
    other.mkdir()
    b = load_design(write_design(other, seed=4))
    from swarm_supervisor.calibration.search import trial_seed
    assert trial_seed(a.seed, 0) != trial_seed(b.seed, 0)
    assert a.digest != b.digest
    from swarm_supervisor.calibration.search import open_search
    open_search(a, tmp_path / 'out')
    with pytest.raises(CalibrationError, match='holds the search of another design'):
        open_search(b, tmp_path / 'out')


@pytest.mark.parametrize('changes, message', [
    ({'sampler': 'tpe'}, 'unknown key calibrate.sampler'),
    ({'parameters': {'controller.nope': {'low': 1, 'high': 2}}},
     'calibrate.parameters.controller.nope: no parameter controller.nope'),
    ({'parameters': {'controller.beeclust.alpha': {'low': 5.0, 'high': 2.0}}},
     'calibrate.parameters.controller.beeclust.alpha: low 5.0 must be below high 2.0'),
    ({'parameters': {'controller.beeclust.alpha': {'low': 1.0, 'high': 1e9}}},
     r'calibrate.parameters.controller.beeclust.alpha: high 1000000000.0 is not allowed: '
     r'controller.beeclust.alpha = 1000000000.0 is out of range'),
    ({'parameters': {'controller.beeclust.avoid': {'low': 1, 'high': 2}}},
     'calibrate.parameters.controller.beeclust.avoid: controller.beeclust.avoid is not a number'),
    ({'parameters': {'controller.beeclust.avoid': {'choices': ['turn-away', 'spin']}}},
     "calibrate.parameters.controller.beeclust.avoid: choice 'spin' is not allowed"),
    ({'parameters': {'episode.population': {'low': 5, 'high': 9}}},
     'calibrate.parameters.episode.population: episode.population is set by the studies'),
    ({'parameters': {'controller.beeclust.alpha': {'low': 1.0, 'high': 4.0, 'step': 1}}},
     'calibrate.parameters.controller.beeclust.alpha: step is for whole-number parameters'),
    ({'trials': 0}, r'calibrate.trials = 0: expected a whole number >= 1'),
    ({'screen': {'speeds': [8]}}, r'calibrate.screen: study.speeds\[0\] = 8.0 is out of range'),
    ({'objective': {'ratio_target': -1}}, 'calibrate.objective.ratio_target = -1'),
    ({'purpose': 'tuning'}, "calibrate.purpose = 'tuning': expected one of profile, existence"),
])
def test_a_bad_design_is_refused_naming_the_key(tmp_path, capsys, changes, message):
    design = write_design(tmp_path, **changes)
    with pytest.raises(CalibrationError, match=message):
        load_design(design)
    assert main(['calibrate', str(design), '--out', str(tmp_path / 'out')]) == 2
    assert 'mona-swarm calibrate: error:' in capsys.readouterr().err
    assert not (tmp_path / 'out').exists()
