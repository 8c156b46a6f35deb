"""Metrics are declared entries of one table (swarm_metrics.metrics.METRICS), and a metric added
through the public mechanism, without touching any other file, reaches every consumer.

The added metric is the mean cue under the robots (the cell under each robot's centre). It is
written as a plug-in file in ``tmp_path`` and used two ways: named by a parameter file's
``plugins:`` list for real ``mona-swarm run --bag`` and ``mona-swarm analyze`` processes (the
analysis loads it from the bag's record), and imported in this process (which registers it)
for the completeness checks, the live view's channels, the video's plots, the claims and the
study's figures. ``MONA_SWARM_METRICS``, the deprecated way to name it, still works.
"""

from __future__ import annotations

import csv
import importlib
import json
import math
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from swarm_metrics import metrics
from swarm_metrics import plugins as metrics_errors
from swarm_metrics.bags import checks, completeness
from swarm_metrics.bags.reader import read_episode_bag
from swarm_metrics.metrics import METRICS, Metric, register, unregister

ROOT = Path(__file__).parents[2]
MONA_SWARM = str(Path(sys.executable).parent / 'mona-swarm')
NAME = 'cue_under_robots'
PLUGIN = f'''"""A metric of one's own: the mean cue under the robots' centres."""

import numpy as np

from swarm_metrics.metrics import Metric, register


def cue_under_robots(sample):
    if not len(sample.positions) or sample.cell_size <= 0:
        return float('nan')
    rows, cols = sample.cue.shape
    i = np.clip((sample.positions[:, 1] / sample.cell_size).astype(np.int64), 0, rows - 1)
    j = np.clip((sample.positions[:, 0] / sample.cell_size).astype(np.int64), 0, cols - 1)
    return float(sample.cue[i, j].mean(dtype=np.float64))


METRIC = register(Metric({NAME!r}, 'cue units (0..255)', 'the mean cue under the robots',
                         cue_under_robots, 'cue under the robots'))
'''
PAPER = ('t', 'mean_cue', 'mean_cue_fraction', 'ratio_near_source', 'coherency')


@pytest.fixture
def plugin_dir(tmp_path: Path) -> Path:
    folder = tmp_path / 'plugins'
    folder.mkdir()
    (folder / 'under_robots.py').write_text(PLUGIN)
    return folder


@pytest.fixture
def registered(plugin_dir: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Metric]:
    """The plugin imported in this process (its metric registered), and removed after."""
    monkeypatch.syspath_prepend(str(plugin_dir))
    try:
        yield importlib.import_module('under_robots').METRIC
    finally:
        unregister(NAME)
        sys.modules.pop('under_robots', None)


def parameter_file(plugin_dir: Path) -> Path:
    """A parameter file beside the plug-in that names it (relative to the file)."""
    path = plugin_dir / 'params.yaml'
    path.write_text('/**:\n  ros__parameters:\n    plugins: [under_robots.py]\n')
    return path


def mona_swarm(*args: object, env: dict[str, str] | None = None,
               cwd: Path = ROOT) -> subprocess.CompletedProcess:
    """The real command."""
    return subprocess.run([MONA_SWARM, *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd, timeout=600)


def read_csv(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    with open(path, newline='') as handle:
        reader = csv.DictReader(handle)
        return list(reader.fieldnames), list(reader)


# --- the table ----------------------------------------------------------------------------

def test_the_paper_metrics_are_the_table_and_keep_their_order():
    assert metrics.COLUMNS == PAPER == metrics.metric_columns()
    assert metrics.PAPER_METRICS == PAPER[1:] == metrics.metric_names()
    assert metrics.plotted() == (('mean_cue_fraction', 'mean cue / initial'),
                                 ('ratio_near_source', 'ratio near source'),
                                 ('coherency', 'coherency (m)'))
    for metric in METRICS.values():
        assert metric.doc and metric.unit in ('', 'm', 'cue units (0..255)')


def test_a_row_is_the_entries_computed_in_table_order():
    rng = np.random.default_rng(3)
    cue = rng.integers(0, 255, (40, 40)).astype(np.float32)
    positions = rng.uniform(0, 2.85, (7, 2))
    params = metrics.MetricsParams()
    row = metrics.sample(5.0, cue, 80.0, positions, np.array([1.4, 1.4]), params)
    assert list(row) == list(PAPER)
    level = float(cue.mean(dtype=np.float64))
    assert row['mean_cue'] == level and row['mean_cue_fraction'] == level / 80.0
    assert row['ratio_near_source'] == metrics.ratio_near_source(positions,
                                                                 np.array([[1.4, 1.4]]), 0.7)
    assert row['coherency'] == metrics.coherency(positions)
    assert math.isnan(metrics.sample(0.0, cue, 0.0, positions, np.zeros(2),
                                     params)['mean_cue_fraction'])


@pytest.mark.parametrize('name', ['t', '2fast', 'with-dash', 'mean_cue_fraction_west',
                                  'ratio_near_me', ''])
def test_a_bad_name_is_refused(name):
    with pytest.raises(ValueError, match='metric name'):
        register(Metric(name, '', 'x', lambda sample: 0.0))


def test_a_name_is_registered_once_and_the_papers_stay():
    with pytest.raises(ValueError, match='registered already'):
        register(Metric('coherency', 'm', 'another', lambda sample: 0.0))
    with pytest.raises(ValueError, match="paper's"):
        unregister('coherency')
    unregister('never_registered')  # nothing to do
    assert metrics.metric_names() == PAPER[1:]


def test_the_deprecated_variable_still_names_a_metric_module(plugin_dir: Path, tmp_path: Path):
    env = dict(os.environ, MONA_SWARM_METRICS='under_robots',
               PYTHONPATH=os.pathsep.join(filter(None, (str(plugin_dir),
                                                        os.environ.get('PYTHONPATH')))))
    done = mona_swarm('run', '--population', 4, '--duration', 3, '--out', tmp_path / 'old',
                      env=env)
    assert done.returncode == 0, done.stderr
    assert 'MONA_SWARM_METRICS is deprecated' in done.stderr
    assert read_csv(tmp_path / 'old' / 'metrics.csv')[0] == [*PAPER, NAME]
    [plugin] = json.loads((tmp_path / 'old' / 'episode.json').read_text())['plugins']
    assert (plugin['module'], plugin['origin']) == ('under_robots', 'MONA_SWARM_METRICS')
    # A module it names that cannot be imported: one line, exit 2, nothing written.
    env['MONA_SWARM_METRICS'] = 'no_such_metrics_module'
    done = mona_swarm('run', '--out', tmp_path / 'never', env=env)
    assert done.returncode == 2 and not (tmp_path / 'never').exists()
    assert "MONA_SWARM_METRICS: cannot import 'no_such_metrics_module'" in done.stderr
    assert 'Traceback' not in done.stderr


@pytest.mark.parametrize('compute, message', [
    (lambda sample: sample.positions[:, 0], r"'odd' returned an array of shape \(7,\), not one"),
    (lambda sample: None, r"'odd' returned None, not one number"),
    (lambda sample: 1 / 0, r"'odd' raised ZeroDivisionError: division by zero \(\S*"
                           r'test_metric_entries\.py, line \d+\): fix its compute'),
])
def test_a_metric_that_gives_no_number_is_named(compute, message):
    register(Metric('odd', '', 'a metric of a user', compute))
    try:
        with pytest.raises(metrics_errors.MetricError, match=message):
            metrics.sample(0.0, np.zeros((4, 4), np.float32), 1.0,
                           np.random.default_rng(1).uniform(0, 2, (7, 2)), np.zeros(2),
                           metrics.MetricsParams())
    finally:
        unregister('odd')


# --- a metric added in one place reaches every consumer ------------------------------------

def test_an_added_metric_is_in_metrics_csv_the_bag_analyze_and_the_checks(
        plugin_dir: Path, tmp_path: Path, registered: Metric):
    run = tmp_path / 'run'
    done = mona_swarm('run', '--config', parameter_file(plugin_dir), '--population', 6,
                      '--duration', 12, '--seed', 4, '--out', run, '--bag')
    assert done.returncode == 0, done.stderr  # the bag's online samples equal the rows
    header, rows = read_csv(run / 'metrics.csv')
    assert header == [*PAPER, NAME]  # after the paper's four, which keep their order
    values = [float(row[NAME]) for row in rows]
    assert len(values) == 13 and all(0 < v <= 255 for v in values)

    # On its topic in the embedded runner's bag, one sample per second, equal to the CSV.
    bag = read_episode_bag(run / 'bag')
    assert [value for _, value in bag.metrics[NAME]] == values
    assert bag.report.topics[f'/metrics/{NAME}'] == 13

    # mona-swarm analyze recomputes it from the bag, loading the plug-in the bag records (run
    # from another folder: the path is absolute), and its checks pass.
    analysed = tmp_path / 'analysed'
    done = mona_swarm('analyze', run / 'bag', '--out', analysed, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    header, rows = read_csv(analysed / 'metrics.csv')
    assert header == [*PAPER, NAME]
    assert [float(row[NAME]) for row in rows] == values
    record = json.loads((analysed / 'episode.json').read_text())
    assert record['complete'] and record['completeness'] == []

    # In this process too: the checks cover it. Lost samples and a wrong value are findings.
    result, findings = completeness.check_bag(bag)
    assert findings == [] and [row[NAME] for row in result.rows] == values
    assert result.online_max_diff == 0.0
    lost = dict(bag.metrics, **{NAME: bag.metrics[NAME][:4] + bag.metrics[NAME][6:]})
    [finding] = checks.check_online(lost, result.setup.start_ns, 12.0, 1.0)
    assert finding.check == 'samples' and 'missing t = 4-5 s' in finding.detail
    bag.metrics[NAME] = [(t, v + 0.5 if k == 3 else v)
                         for k, (t, v) in enumerate(bag.metrics[NAME])]
    [finding] = completeness.check_recomputation(bag, completeness.recompute(bag))
    assert finding.check == 'online_metrics' and finding.where == f'/metrics/{NAME}'
    assert 'the first at t = 3 s' in finding.detail


def test_an_added_metric_reaches_the_views_the_claims_and_the_figures(
        registered: Metric, tmp_path: Path):
    from swarm_supervisor.analysis import beyond_figures, claims, figures
    from swarm_supervisor.media import live
    from swarm_supervisor.outputs import bag

    topic = f'/metrics/{NAME}'
    assert metrics.metric_columns() == (*PAPER, NAME)
    assert bag.TOPICS[topic] == bag.TOPICS['/metrics/coherency']  # same type and QoS
    assert live.LIVE_TOPICS[topic] == 'std_msgs/msg/Float64'
    assert metrics.plotted()[-1] == (NAME, 'cue under the robots')  # a fourth video plot
    # A claim may test it.
    claim = claims.parse_claim({'id': 'under', 'where': 'ours', 'paper': '-', 'check': {
        'kind': 'threshold', 'metric': NAME, 'at': 'end', 'op': '<', 'value': 200}})
    assert claim.params['metric'] == NAME
    # The study's figure of a metric beyond the paper's, from a tidy table that has it.
    t = np.arange(0.0, 11.0)
    table = pd.DataFrame([{'population': n, 'speed': 0.08, 'seed': s, 't': time,
                           'mean_cue': 1.0, 'mean_cue_fraction': 1.0,
                           'ratio_near_source': 0.5, 'coherency': 1.0,
                           NAME: 100.0 + n * time + s}
                          for n in (10, 30) for s in (1, 2) for time in t])
    assert beyond_figures.extra_metrics(table) == [NAME]
    assert [label for label, _ in figures.variants(table)] == ['']  # a metric is no factor
    path = tmp_path / beyond_figures.FIG_METRIC.format(NAME)
    assert beyond_figures.fig_metric(table, path, NAME) == ''
    assert path.stat().st_size > 10_000
