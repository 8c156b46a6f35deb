"""One verdict on a bag: every consumer judges it with swarm_metrics.bags.completeness.check_bag.

The recorder when it closes a bag (the metrics node's and the embedded runner's), the launcher
before it exits 0, ``analyze``, ``replay`` and ``study --from-episodes`` (through the findings
``analyze`` records) cannot disagree about a bag: a finding planted in that one function's
answer is the answer of each of them, and no module of the project runs a bag check of its
own.
"""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from swarm_metrics.bags import completeness
from swarm_metrics.bags.checks import Finding
from swarm_supervisor.cli import main
from swarm_supervisor.config import load_config
from swarm_supervisor.outputs.bag import RecordError, record_episode
from swarm_supervisor.system.records import RUN_FILE, incomplete_records

SRC = Path(__file__).resolve().parents[2] / 'src'
CONFIG = load_config().replace(episode={'population': 8, 'duration': 4.0, 'seed': 5})
PLANTED = Finding('sources', '/world/sources', 'planted by the test')


@pytest.fixture
def planted(monkeypatch) -> list[Path]:
    """check_bag answers what it would, plus PLANTED; returns the bags it was asked about."""
    judged: list[Path] = []
    real = completeness.check_bag

    def check_bag(bag, snapshot_times=()):
        judged.append(bag.path)
        result, findings = real(bag, snapshot_times)
        return result, [*findings, PLANTED]

    monkeypatch.setattr(completeness, 'check_bag', check_bag)
    return judged


@pytest.fixture(scope='module')
def bag(tmp_path_factory) -> Path:
    """A complete bag of an embedded episode, recorded as the metrics node records it."""
    _, closed = record_episode(CONFIG, tmp_path_factory.mktemp('episode'))
    assert closed.complete and completeness.check_bag_file(closed.path) == []
    return closed.path


def test_the_recorder_closes_with_the_verdict(planted, tmp_path):
    with pytest.raises(RecordError, match='planted by the test'):
        record_episode(CONFIG, tmp_path)
    assert planted == [tmp_path / 'bag' / 'bag.mcap']  # its own bag, read back once


def test_the_launcher_exits_with_the_verdict(bag, planted, tmp_path):
    (tmp_path / RUN_FILE).write_text(json.dumps({'episodes': [
        {'episode': 0, 'records': {'metrics': {'path': str(bag), 'complete': True}}}]}))
    [problem] = incomplete_records(tmp_path)
    assert f'{bag} (episode 0, recorder metrics) is incomplete' in problem
    assert 'planted by the test' in problem and planted == [bag / 'bag.mcap']


def test_analyze_replay_and_the_study_refuse_with_the_verdict(bag, planted, tmp_path,
                                                              capsys):
    assert main(['analyze', str(bag), '--out', str(tmp_path / 'refused')]) == 1
    assert 'fails the sources check' in capsys.readouterr().err
    assert not (tmp_path / 'refused').exists()
    assert main(['replay', str(bag), '--rate', '0', '--delay', '0']) == 1
    assert 'planted by the test' in capsys.readouterr().err

    folder = tmp_path / 'episodes' / 'seed5'
    assert main(['analyze', str(bag), '--out', str(folder), '--allow-incomplete']) == 0
    record = json.loads((folder / 'episode.json').read_text())
    assert record['complete'] is False and record['completeness'] == [PLANTED.to_dict()]
    capsys.readouterr()
    assert main(['study', '--from-episodes', str(tmp_path / 'episodes'),
                 '--out', str(tmp_path / 'study')]) == 1
    assert 'planted by the test' in capsys.readouterr().err
    assert planted == [bag / 'bag.mcap'] * 3  # analyze twice, replay once


@pytest.mark.ros
def test_without_a_planted_finding_every_consumer_accepts_the_bag(bag, tmp_path, ros_env):
    (tmp_path / RUN_FILE).write_text(json.dumps({'episodes': [
        {'episode': 0, 'records': {'metrics': {'path': str(bag), 'complete': True}}}]}))
    assert incomplete_records(tmp_path) == []
    assert main(['analyze', str(bag), '--out', str(tmp_path / 'analysis')]) == 0
    assert json.loads((tmp_path / 'analysis' / 'episode.json').read_text())['complete']
    assert main(['replay', str(bag), '--rate', '0', '--delay', '0']) == 0


def test_a_missing_run_record_or_an_episode_without_a_bag_fails_the_run(tmp_path):
    assert 'does not list the episodes' in incomplete_records(tmp_path)[0]
    (tmp_path / RUN_FILE).write_text(json.dumps({'episodes': [{'episode': 0, 'records': {}}]}))
    assert incomplete_records(tmp_path) == [f'episode 0 has no record in {tmp_path / RUN_FILE}']
    # The live view's word is no record on disk: alone, the episode still has none.
    (tmp_path / RUN_FILE).write_text(json.dumps({'episodes': [{'episode': 0, 'records': {
        'live': {'path': 'ws://127.0.0.1:8765', 'complete': True, 'problems': []}}}]}))
    assert incomplete_records(tmp_path) == [f'episode 0 has no record in {tmp_path / RUN_FILE}']
    (tmp_path / RUN_FILE).write_text(json.dumps({'episodes': [
        {'episode': 0, 'records': {'metrics': {'path': str(tmp_path / 'gone')}}}]}))
    [problem] = incomplete_records(tmp_path)
    assert 'fails the readable check' in problem


#: The individual checks: only completeness.check_bag runs them on a bag. study.table runs
#: check_rows on an episode folder's metrics.csv (no bag there), the one exception.
CHECKS = {'check_announcement', 'check_finished', 'check_cleaning', 'check_rows',
          'check_online', 'check_cue_maps', 'check_online_metrics', 'check_states',
          'check_sources', 'check_recomputation', 'recompute'}
ALLOWED = {('swarm_supervisor/study/table.py', 'check_rows')}


def test_no_module_judges_a_bag_with_checks_of_its_own():
    used = set()
    for path in SRC.rglob('*.py'):
        if path.relative_to(SRC).as_posix().endswith(
                ('/bags/checks.py', '/bags/completeness.py', '/bags/analysis.py')):
            continue  # where the checks and the recomputation are
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call):
                name = getattr(node.func, 'attr', getattr(node.func, 'id', None))
                if name in CHECKS:
                    package = path.relative_to(SRC).parts[1:]
                    used.add(('/'.join(package), name))
    assert used <= ALLOWED, sorted(used - ALLOWED)
