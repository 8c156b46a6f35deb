"""The study end to end: a tiny design through ``mona-swarm study``, its outputs, resuming,
redoing a half-written episode and analysing episode folders (Ctrl-C:
test_study_interrupt.py)."""

import csv
import dataclasses
import json
import shutil
from pathlib import Path

import pandas as pd
import pytest

from swarm_supervisor import outputs, study
from swarm_supervisor.analysis.anova import anova
from swarm_supervisor.cli import main
from swarm_supervisor.config import load_config, write_ros_yaml

TINY = {'populations': [3, 5], 'speeds': [0.04, 0.08], 'seeds': [1, 2], 'duration': 24.0,
        'snapshot_times': [0.0, 6.0, 24.0]}
RESULT_FILES = ('all_metrics.csv', 'anova_cue.csv', 'anova_coherency.csv', 'report.md',
                'fig3_cue_maps.png', 'fig4_mean_cue.png', 'fig5_ratio_near_source.png',
                'fig6_coherency.png', 'parameters.yaml', 'study.json')
PNG_SIGNATURE = b'\x89PNG\r\n\x1a\n'


def tiny_config(path: Path, **study_values) -> Path:
    config = load_config().replace(study={**TINY, **study_values})
    write_ros_yaml(config, path)
    return path


def episode_stamps(out: Path) -> dict[str, int]:
    """Each episode folder's episode.json modification time (ns): rewritten iff re-run."""
    return {folder.name: (folder / outputs.EPISODE_FILE).stat().st_mtime_ns
            for folder in sorted((out / study.EPISODES_DIR).iterdir())}


@pytest.fixture(scope='module')
def finished(tmp_path_factory) -> Path:
    """A finished tiny study (8 episodes of 24 s) run through the command line."""
    root = tmp_path_factory.mktemp('study')
    out = root / 'out'
    status = main(['study', '--out', str(out), '--config', str(tiny_config(root / 'tiny.yaml')),
                   '--jobs', '2'])
    assert status == 0
    return out


def test_every_output_is_written_and_well_formed(finished):
    for name in RESULT_FILES:
        assert (finished / name).stat().st_size > 0, name
    for name in RESULT_FILES:
        if name.endswith('.png'):
            assert (finished / name).read_bytes()[:8] == PNG_SIGNATURE, name
    with open(finished / 'all_metrics.csv', newline='') as handle:
        header = next(csv.reader(handle))
    assert header == ['population', 'speed', 'seed', 't', 'mean_cue', 'mean_cue_fraction',
                      'ratio_near_source', 'coherency']
    table = pd.read_csv(finished / 'all_metrics.csv')
    assert len(table) == 2 * 2 * 2 * 25  # episodes x samples at t = 0..24 s
    assert sorted(table.groupby(['population', 'speed', 'seed']).size().unique()) == [25]
    assert (table['mean_cue_fraction'] <= 1.0).all()
    for name in ('anova_cue.csv', 'anova_coherency.csv'):
        anova_table = pd.read_csv(finished / name)
        assert list(anova_table.columns) == ['factor', 'levels', 'df', 'sum_sq', 'F', 'p',
                                             'eta_sq']
        assert list(anova_table['factor']) == ['time', 'population', 'speed', 'residual']
    report = (finished / 'report.md').read_text()
    for name in RESULT_FILES:
        if name.endswith(('.png', '.csv')) or name == 'parameters.yaml':
            assert f']({name})' in report, name
    assert 'N = 3' in report and 'Wall time' in report
    assert '- Monas: the `idealised` profile' in report
    folders = sorted((finished / study.EPISODES_DIR).iterdir())
    assert [f.name for f in folders] == sorted(
        f'N{n}_v{v}_s{s}' for n in (3, 5) for v in (4, 8) for s in (1, 2))
    record = json.loads((folders[0] / outputs.EPISODE_FILE).read_text())
    assert record['parameters']['episode']['duration'] == 24.0
    with open(finished / 'parameters.yaml') as handle:
        assert load_config(handle.name).study.populations == (3, 5)


def test_anova_tables_are_reproducible_from_the_tidy_table(finished):
    table = study.read_table(finished / 'all_metrics.csv')
    for response, name in (('mean_cue', 'anova_cue.csv'), ('coherency', 'anova_coherency.csv')):
        pd.testing.assert_frame_equal(anova(table, response), pd.read_csv(finished / name),
                                      check_dtype=False)


def test_rerun_runs_no_episode_again(finished, tmp_path):
    out = tmp_path / 'out'
    shutil.copytree(finished, out)
    before = episode_stamps(out)
    config = tiny_config(tmp_path / 'tiny.yaml')
    assert main(['study', '--out', str(out), '--config', str(config), '--jobs', '2']) == 0
    assert episode_stamps(out) == before
    last = study.read_invocations(out)[-1]
    assert (last['ran'], last['kept']) == (0, 8)
    assert (out / 'report.md').stat().st_size > 0


def test_half_written_episode_is_redone_and_only_it(finished, tmp_path):
    out = tmp_path / 'out'
    shutil.copytree(finished, out)
    broken = out / study.EPISODES_DIR / 'N5_v8_s2'
    expected = (broken / outputs.METRICS_FILE).read_text()
    (broken / outputs.EPISODE_FILE).unlink()  # as if killed before the last write
    (broken / outputs.METRICS_FILE).write_text('t,mean_cue\n0.0,1')  # and a torn CSV
    before = {f.name: (f / outputs.EPISODE_FILE).stat().st_mtime_ns
              for f in (out / study.EPISODES_DIR).iterdir() if f != broken}
    config = tiny_config(tmp_path / 'tiny.yaml')
    # The study itself, in this process (the resume is its work; the figures are not looked at).
    study.run_study(load_config(config), out, jobs=1, progress=False, start_method='fork')
    after = episode_stamps(out)
    assert {name: after[name] for name in before} == before
    assert outputs.episode_complete(broken)
    assert (broken / outputs.METRICS_FILE).read_text() == expected  # same seed, same episode
    last = study.read_invocations(out)[-1]
    assert (last['ran'], last['kept']) == (1, 7)
    assert list(last['episode_wall_time_s']) == ['N5_v8_s2']


def test_changed_parameters_do_not_mix_with_finished_episodes(finished, tmp_path, capsys):
    out = tmp_path / 'out'
    shutil.copytree(finished, out)
    before = episode_stamps(out)
    saved = (out / 'parameters.yaml').read_text()
    config = tiny_config(tmp_path / 'longer.yaml', duration=30.0)
    assert main(['study', '--out', str(out), '--config', str(config)]) == 2
    error = capsys.readouterr().err
    assert 'episode.duration' in error and 'N3_v4_s1' in error
    assert episode_stamps(out) == before
    assert (out / 'parameters.yaml').read_text() == saved


def test_an_episode_recorded_before_a_parameter_existed_is_kept(finished, tmp_path):
    """A record without a parameter added to the schema since ran its default: kept."""
    out = tmp_path / 'out'
    shutil.copytree(finished, out)
    for record_path in (out / study.EPISODES_DIR).glob(f'*/{outputs.EPISODE_FILE}'):
        record = json.loads(record_path.read_text())
        del record['parameters']['controller']['kind']  # as written before controller.kind
        record_path.write_text(json.dumps(record))
    before = episode_stamps(out)
    study.run_study(load_config(finished / 'parameters.yaml'), out, progress=False)
    assert episode_stamps(out) == before  # nothing ran again
    assert study.read_invocations(out)[-1]['ran'] == 0


def test_from_episodes_analyses_folders_without_snapshots(finished, tmp_path):
    source = tmp_path / 'bags'
    for folder in (finished / study.EPISODES_DIR).iterdir():
        target = source / f'bag_{folder.name}'
        target.mkdir(parents=True)
        for name in (outputs.METRICS_FILE, outputs.EPISODE_FILE):  # what `analyze` writes
            shutil.copy(folder / name, target / name)
    out = tmp_path / 'analysis'
    assert main(['study', '--out', str(out), '--from-episodes', str(source)]) == 0
    report = (out / 'report.md').read_text()
    assert 'skipped: no episode folder holds snapshots.npz' in report
    assert not (out / 'fig3_cue_maps.png').exists()
    for name in RESULT_FILES:
        if name not in ('fig3_cue_maps.png', 'parameters.yaml', 'study.json'):
            assert (out / name).stat().st_size > 0, name
    pd.testing.assert_frame_equal(pd.read_csv(out / 'all_metrics.csv'),
                                  pd.read_csv(finished / 'all_metrics.csv'))


def test_from_episodes_refuses_options_that_run_episodes(finished, tmp_path, capsys):
    status = main(['study', '--out', str(tmp_path / 'a'), '--batch-size', '4',
                   '--from-episodes', str(finished / study.EPISODES_DIR)])
    assert status == 2
    assert '--batch-size cannot be combined with --from-episodes' in capsys.readouterr().err
    assert not (tmp_path / 'a').exists()


def test_from_episodes_rejects_the_same_episode_twice(finished, tmp_path, capsys):
    copy = tmp_path / 'copy'
    shutil.copytree(finished / study.EPISODES_DIR, copy)
    status = main(['study', '--out', str(tmp_path / 'a'), '--from-episodes',
                   str(finished / study.EPISODES_DIR), str(copy)])
    assert status == 2
    assert 'same episode' in capsys.readouterr().err


def test_quick_design_is_small_and_keeps_every_output():
    quick = study.quick_study(load_config().study)
    assert quick.populations == (5, 10) and quick.speeds == (0.04, 0.08)
    assert len(quick.seeds) == 2 and quick.duration == 60.0
    assert quick.snapshot_times == (0.0, 15.0, 60.0)
    assert study.snapshot_times(quick) == (0.0, 15.0, 60.0)
    assert len(study.design(dataclasses.replace(load_config(), study=quick))) == 8
