"""What a study refuses before anything runs (a design that cannot run, a folder of another
design or of another kind), --overwrite, and a study too small for an ANOVA."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from swarm_supervisor import study
from swarm_supervisor.cli import main
from swarm_supervisor.config import load_config, write_ros_yaml

#: One cell, one seed, 3 s: no residual degrees of freedom for an ANOVA.
ONE = {'populations': [3], 'speeds': [0.08], 'seeds': [1], 'duration': 3.0,
       'snapshot_times': [0.0, 3.0]}


def config(**values):
    return load_config().replace(study={**ONE, **values})


def design_file(path: Path, **values) -> Path:
    write_ros_yaml(config(**values), path)
    return path


@pytest.mark.parametrize('values, message', [
    ({'populations': [10, 2000]}, 'episode N2000_v8_s1: population 2000 does not fit a'),
    ({'populations': [0, 3]}, 'study.populations lists 0: an episode needs at least one robot'),
    ({'seeds': [4, 5, 4]}, 'study.seeds lists 4 more than once'),
    ({'speeds': [0.04, 0.08, 0.04]}, 'study.speeds lists 0.04 more than once'),
])
def test_a_design_that_cannot_run_is_refused_before_anything(values, message):
    with pytest.raises(study.StudyError, match=message.replace('.', r'\.')):
        study.check_design(config(**values))


def test_a_factor_that_shrinks_the_arena_is_checked_per_cell():
    crowded = config(populations=[300], factors={'world.arena_side': [2.85, 1.6]})
    with pytest.raises(study.StudyError, match='world.arena_side=1.6: population 300 does '
                                                'not fit a 1.6 m arena'):
        study.check_design(crowded)


def test_the_shipped_design_passes():
    assert len(study.check_design(load_config())) == 60


def test_refusals_write_nothing(tmp_path, capsys):
    out = tmp_path / 'out'
    for values in ({'populations': [10, 2000]}, {'seeds': [1, 1]}):
        status = main(['study', '--config', str(design_file(tmp_path / 'd.yaml', **values)),
                       '--out', str(out)])
        assert status == 2
        assert not out.exists()
    error = capsys.readouterr().err
    assert 'Traceback' not in error and error.count('\n') == 2  # one line each


def test_first_difference_names_the_first_key_that_reaches_the_episodes():
    assert study.first_difference(config(), config()) is None
    assert study.first_difference(config(), config(seeds=[1, 2])) == \
        ('study.seeds', [1], [1, 2])
    # The file's own run values (episode.population, ...) are set by the design: ignored.
    other = config().replace(episode={'population': 7})
    assert study.first_difference(config(), other) is None
    assert study.first_difference(config(), config().replace(mona={'ir_range': 0.05}))[0] == \
        'mona.ir_range'


def test_another_design_is_refused_then_overwrite_replaces_the_folder(tmp_path, capsys):
    out = tmp_path / 'out'
    one = design_file(tmp_path / 'one.yaml')
    assert main(['study', '--config', str(one), '--out', str(out), '--jobs', '1']) == 0
    report = (out / 'report.md').read_text()
    # One episode: no ANOVA, said in its place; the rest of the report is there.
    assert re.search(r'\*\*Not fitted\*\*: \d+ observations leave no residual degrees', report)
    assert 'ANOVA of the mean cue: not fitted' in report
    assert "share their batch's wall time" in report
    assert not (out / 'anova_cue.csv').exists() and (out / 'fig4_mean_cue.png').exists()
    before = {p: p.read_bytes() for p in out.rglob('*') if p.is_file()}
    capsys.readouterr()

    two = design_file(tmp_path / 'two.yaml', seeds=[1, 2])
    assert main(['study', '--config', str(two), '--out', str(out)]) == 2
    error = capsys.readouterr().err
    assert f'--out {out} holds a study of another design: study.seeds = [1] there, [1, 2] ' \
           'here' in error and '--overwrite' in error
    assert {p: p.read_bytes() for p in out.rglob('*') if p.is_file()} == before

    assert main(['study', '--config', str(two), '--out', str(out), '--jobs', '1',
                 '--overwrite']) == 0
    assert [p.name for p in sorted((out / study.EPISODES_DIR).iterdir())] == \
        ['N3_v8_s1', 'N3_v8_s2']
    runs = study.read_invocations(out)
    assert len(runs) == 1 and (runs[0]['ran'], runs[0]['outcome']) == (2, 'finished')
    # The same design resumes, running nothing.
    assert main(['study', '--config', str(two), '--out', str(out)]) == 0
    assert study.read_invocations(out)[-1]['ran'] == 0


def test_a_folder_holding_a_run_is_no_study(tmp_path, capsys):
    out = tmp_path / 'run'
    out.mkdir()
    (out / 'run.json').write_text('{}')
    one = design_file(tmp_path / 'one.yaml')
    assert main(['study', '--config', str(one), '--out', str(out)]) == 2
    error = capsys.readouterr().err
    assert 'holds a node-system run' in error and 'not a study run there' in error
    assert '--overwrite' in error
    assert sorted(p.name for p in out.iterdir()) == ['run.json']


def test_quick_design_is_checked_too():
    quick = dataclasses.replace(load_config(), study=study.quick_study(load_config().study))
    assert len(study.check_design(quick)) == 8


def test_an_analysis_replaces_an_analysis_but_not_a_study_or_its_sources(tmp_path, capsys):
    ran = tmp_path / 'ran'
    one = design_file(tmp_path / 'one.yaml')
    assert main(['study', '--config', str(one), '--out', str(ran), '--jobs', '1']) == 0
    episodes = str(ran / study.EPISODES_DIR)
    analysis = tmp_path / 'analysis'
    for _ in range(2):  # an earlier analysis is analysed over
        assert main(['study', '--from-episodes', episodes, '--out', str(analysis)]) == 0
    before = {p: p.read_bytes() for p in ran.rglob('*') if p.is_file()}
    capsys.readouterr()
    assert main(['study', '--from-episodes', str(analysis), episodes, '--out', str(ran)]) == 2
    assert 'holds a study run there' in capsys.readouterr().err
    assert main(['study', '--from-episodes', episodes, '--out', str(ran), '--overwrite']) == 2
    assert 'inside --out' in capsys.readouterr().err
    assert {p: p.read_bytes() for p in ran.rglob('*') if p.is_file()} == before
    # And a study is not run into an analysis.
    assert main(['study', '--config', str(one), '--out', str(analysis)]) == 2
    assert 'holds an analysis of other episodes' in capsys.readouterr().err
