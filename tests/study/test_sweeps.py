"""Sweeps over any parameter: study.factors crossed with the design or varied one at a time,
run, resumed, refused when mixed with another design, analysed and faceted; and every
factor level reproducible from its seed."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mona_controller.schema import ParameterError
from swarm_supervisor import study
from swarm_supervisor.analysis import figures
from swarm_supervisor.cli import main
from swarm_supervisor.config import load_config, write_ros_yaml
from swarm_supervisor.engine.runner import run_episode

SWEEP = {'populations': [6], 'speeds': [0.08], 'seeds': [1, 2], 'duration': 30.0,
         'snapshot_times': [0.0, 30.0], 'factors': {'mona.ir_range': [0.02, 0.1]}}


def sweep_config(path: Path, **study_values) -> Path:
    config = load_config().replace(study={**SWEEP, **study_values})
    write_ros_yaml(config, path)
    return path


@pytest.fixture(scope='module')
def swept(tmp_path_factory) -> tuple[Path, Path]:
    """A finished sweep over mona.ir_range (4 episodes of 30 s): (output, parameter file)."""
    root = tmp_path_factory.mktemp('sweep')
    config = sweep_config(root / 'sweep.yaml')
    assert main(['study', '--out', str(root / 'out'), '--config', str(config),
                 '--jobs', '2']) == 0
    return root / 'out', config


def test_bad_factors_name_the_key_and_the_problem():
    config = load_config()
    cases = {
        'controller.speed': ([0.04], 'set by the design; use study.speeds'),
        'mona.no_such_key': ([1.0], 'no parameter mona.no_such_key'),
        'study.seeds': ([1], 'no parameter study.seeds'),
        'mona.ir_range': ([0.03, 5.0], 'study.factors.mona.ir_range: mona.ir_range = 5.0 is '
                                       'out of range'),
        'world.cleaning': (['monotone', 'sideways'], "'sideways' is not allowed"),
        'mona.ir_count': ([3, 3], 'repeats a level'),
    }
    for key, (levels, fragment) in cases.items():
        with pytest.raises(ParameterError) as error:
            config.replace(study={'factors': {key: levels}})
        assert fragment in str(error.value), (key, str(error.value))
    with pytest.raises(ParameterError, match='non-empty list'):
        config.replace(study={'factors': {'mona.ir_range': []}})


def test_levels_are_normalised_to_the_parameter_type():
    config = load_config().replace(study={'factors': {'controller.beeclust.alpha': [2, 0.5]}})
    assert config.study.factors == (('controller.beeclust.alpha', (2.0, 0.5)),)
    assert isinstance(config.study.factors[0][1][0], float)


def test_crossed_design_is_every_combination_with_named_folders():
    config = load_config().replace(study={
        'populations': [10, 20], 'speeds': [0.08], 'seeds': [1],
        'factors': {'mona.ir_range': [0.02, 0.05], 'world.cleaning': ['monotone', 'literal']}})
    specs = study.design(config)
    assert len(specs) == 2 * 2 * 2
    assert specs[0].name == 'N10_v8_s1_mona.ir_range=0.02_world.cleaning=monotone'
    assert len({spec.name for spec in specs}) == len(specs)
    episode = study.episode_config(config, specs[-1])
    assert episode.mona.ir_range == 0.05 and episode.world.cleaning == 'literal'
    assert episode.episode.population == 20


def test_one_at_a_time_design_varies_each_factor_alone():
    config = load_config().replace(study={
        'populations': [10], 'speeds': [0.08], 'seeds': [1],
        'factor_design': 'one-at-a-time',
        'factors': {'mona.ir_range': [0.02, 0.03, 0.05], 'world.cleaning': ['literal']}})
    names = [spec.name for spec in study.design(config)]
    # The shipped values (ir_range 0.03, monotone) form the shared base cell.
    assert names == ['N10_v8_s1', 'N10_v8_s1_mona.ir_range=0.02',
                     'N10_v8_s1_mona.ir_range=0.05', 'N10_v8_s1_world.cleaning=literal']
    levels = [dict(spec.levels) for spec in study.design(config)]
    assert levels[3] == {'mona.ir_range': 0.03, 'world.cleaning': 'literal'}


def test_shipped_sensitivity_design_loads():
    path = Path(__file__).resolve().parents[2] / 'ros_ws/config/designs/sensitivity.yaml'
    config = load_config(path)
    assert config.study.factor_design == 'one-at-a-time'
    cells = study.factor_cells(config)
    assert cells[0][1] == ()  # the base cell: every decision at its shipped value
    assert len(cells) == 1 + sum(len(levels) - 1 for _, levels in config.study.factors)


def test_sweep_runs_into_a_table_with_its_factor(swept):
    out, _ = swept
    table = pd.read_csv(out / study.TABLE_FILE)
    assert list(table.columns[:4]) == ['population', 'speed', 'seed', 'mona.ir_range']
    assert study.design_factors(table) == ['mona.ir_range']
    assert sorted(table['mona.ir_range'].unique()) == [0.02, 0.1]
    assert len(table) == 4 * 31
    folders = sorted(p.name for p in (out / study.EPISODES_DIR).iterdir())
    assert folders[0] == 'N6_v8_s1_mona.ir_range=0.02'
    # --from-episodes finds the factor by itself: the parameter that varies.
    assert study.varying_parameters(sorted((out / study.EPISODES_DIR).iterdir())) == \
        ['mona.ir_range']


def test_sweep_anova_report_and_claim_matrix_have_the_factor(swept):
    out, _ = swept
    anova = pd.read_csv(out / 'anova_cue.csv')
    assert 'mona.ir_range' in set(anova['factor'])
    report = (out / 'report.md').read_text()
    assert '- factor `mona.ir_range`: 0.02, 0.1' in report
    assert 'differ between episodes' not in report  # a declared factor is no accident
    matrix = pd.read_csv(out / 'sensitivity.csv')
    assert list(matrix['variant']) == ['mona.ir_range = 0.02', 'mona.ir_range = 0.1']
    assert '(sensitivity.md)' in report


def test_figures_facet_by_the_factor(swept, tmp_path):
    out, _ = swept
    table = pd.read_csv(out / study.TABLE_FILE)
    facets = figures.variants(table)
    assert [label for label, _ in facets] == ['mona.ir_range = 0.02', 'mona.ir_range = 0.1']
    assert sum(len(rows) for _, rows in facets) == len(table)
    for name in (figures.FIG4, figures.FIG5, figures.FIG6):
        assert (out / name).stat().st_size > 0
    # A faceted figure is wider than the same data drawn without the factor.
    figures.fig6_coherency(table.drop(columns=['mona.ir_range'])
                           .drop_duplicates(['population', 'speed', 'seed', 't']),
                           tmp_path / 'single.png')
    import matplotlib.image as image
    assert image.imread(out / figures.FIG6).shape[1] > image.imread(tmp_path / 'single.png'
                                                                     ).shape[1]


def test_sweep_resumes_and_refuses_another_design(swept, tmp_path):
    out, config = swept
    assert main(['study', '--out', str(out), '--config', str(config)]) == 0
    assert study.read_invocations(out)[-1]['ran'] == 0
    # The same folders under another value of a parameter that is not a factor: refused.
    other = load_config(config).replace(world={'cleaning_peak': 6.0})
    write_ros_yaml(other, tmp_path / 'other.yaml')
    before = (out / study.PARAMETERS_FILE).read_text()
    assert main(['study', '--out', str(out), '--config', str(tmp_path / 'other.yaml')]) == 2
    assert (out / study.PARAMETERS_FILE).read_text() == before


@pytest.mark.parametrize('key, levels', [
    ('mona.ir_range', (0.015, 0.06)), ('mona.ir_count', (3, 7)),
    ('sensing.ground_footprint', (0.03, 0.05)), ('mona.wheel_separation', (0.05, 0.08)),
    ('controller.beeclust.avoid', ('random-turn',)), ('world.cleaning', ('literal',)),
    ('controller.beeclust.turn_speed', (0.02, 0.08)), ('controller.beeclust.alpha', (10.0,)),
])
def test_every_factor_level_is_reproducible_and_matters(key, levels):
    """Same seed, same run for each level; and the level changes the run."""
    base = load_config().replace(episode={'population': 12, 'duration': 40.0, 'seed': 3})
    default = run_episode(base)
    for level in levels:
        config = base.with_values({key: level})
        first, second = run_episode(config), run_episode(config)
        assert json.dumps(first.metrics) == json.dumps(second.metrics)
        np.testing.assert_array_equal(first.final_poses, second.final_poses)
        np.testing.assert_array_equal(first.final_cue, second.final_cue)
        assert not np.array_equal(first.final_poses, default.final_poses), (key, level)
