"""A study of a design with several moving, leaking sources: the per-source metrics reach the
tidy table and a figure of their own, and are never mistaken for design factors."""

from __future__ import annotations

import pandas as pd
import pytest

from swarm_supervisor import study
from swarm_supervisor.analysis import beyond_figures, figures
from swarm_supervisor.cli import main
from swarm_supervisor.config import load_config, write_ros_yaml

WORLD = {'sources': {'west': [0.8, 2.0, 0.5, 255.0], 'east': [2.1, 0.9, 0.6, 255.0]},
         'source_profile': {'east': ['gaussian']},
         'source_emission': {'west': [2.0], 'east': [2.0]},
         'source_velocity': {'west': [0.01, -0.005]}, 'half_life': 100.0}
DESIGN = {'populations': [8], 'speeds': [0.08], 'seeds': [1, 2], 'duration': 20.0,
          'snapshot_times': [0.0, 20.0], 'factors': {'world.diffusion': [0.0, 1e-4]}}


@pytest.fixture(scope='module')
def leaks_study(tmp_path_factory):
    root = tmp_path_factory.mktemp('leaks_study')
    write_ros_yaml(load_config().replace(world=WORLD, study=DESIGN), root / 'leaks.yaml')
    assert main(['study', '--out', str(root / 'out'), '--config', str(root / 'leaks.yaml'),
                 '--jobs', '2']) == 0
    return root / 'out'


def test_per_source_metrics_reach_the_table_and_are_not_factors(leaks_study):
    table = pd.read_csv(leaks_study / 'all_metrics.csv')
    assert list(table.columns[-4:]) == ['mean_cue_fraction_east', 'ratio_near_east',
                                        'mean_cue_fraction_west', 'ratio_near_west']
    assert study.design_factors(table) == ['world.diffusion']
    assert len(table) == 4 * 21  # 2 seeds x 2 levels x (t = 0 .. 20 s)
    total = table['mean_cue_fraction_east'] + table['mean_cue_fraction_west']
    assert (total - table['mean_cue_fraction']).abs().max() < 1e-9
    assert (table['ratio_near_east'] + table['ratio_near_west']
            == table['ratio_near_source']).all()
    # the leaks refill what evaporates (half-life 100 s: 0.87 would be left after 20 s)
    end = table[table['t'] == 20.0]
    assert (end['mean_cue_fraction'] > 2 ** (-20 / 100) + 0.02).all()

def test_the_per_source_figure_is_drawn_and_named_in_the_report(leaks_study):
    assert (leaks_study / beyond_figures.FIG_SOURCES).stat().st_size > 10_000
    report = (leaks_study / 'report.md').read_text()
    assert 'Cue near each source' in report and beyond_figures.FIG_SOURCES in report


def test_a_one_source_study_draws_no_per_source_figure(tmp_path):
    table = pd.DataFrame({'population': [5], 'speed': [0.08], 'seed': [1], 't': [0.0],
                          'mean_cue': [1.0], 'mean_cue_fraction': [1.0],
                          'ratio_near_source': [0.0], 'coherency': [1.0]})
    with pytest.raises(figures.FigureSkipped):
        beyond_figures.fig_sources(table, tmp_path / 'x.png')
