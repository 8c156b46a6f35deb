"""Completeness checks: a bag that is readable but incomplete is refused by every consumer.

Real bags (an embedded episode recorded as the metrics node records it, with messages left
out to damage it) and the real ``mona-swarm`` command; the checks themselves on synthetic rows.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from swarm_metrics.bags import checks, completeness
from swarm_metrics.bags.checks import Finding
from swarm_metrics.bags.reader import read_episode_bag
from swarm_metrics.metrics import metric_names
from swarm_supervisor import study
from swarm_supervisor.cli import main
from swarm_supervisor.config import load_config
from swarm_world.params import WorldParams

from bagtools import embedded_episode_bag

MONA_SWARM = str(Path(sys.executable).parent / 'mona-swarm')
CONFIG = load_config().replace(episode={'population': 20, 'duration': 20.0, 'seed': 1})
START_NS = 7 * 10**9  # embedded_episode_bag's default


def at(seconds: float) -> int:
    """The log time of ``seconds`` after the episode's start."""
    return START_NS + round(seconds * 1e9)


#: name -> (embedded_episode_bag options, a check that must fail, text its finding must hold)
DAMAGE = {
    'first_seconds': ({'drop': lambda topic, ns: topic != '/episode' and ns < at(5)},
                      'samples', '4 of 21 samples (every 1 s from t = 0 to 20 s) are missing, '
                                 'the first at t = 1 s'),
    'middle_gap': ({'drop': lambda topic, ns: at(10) <= ns < at(13)},
                   'samples', '3 of 21 samples (every 1 s from t = 0 to 20 s) are missing, '
                              'the first at t = 10 s (missing t = 10-12 s)'),
    'not_finished': ({'finished': False}, 'finished', 'never reported episode 0 "finished"'),
    'lost_cleaning_event': ({'drop': lambda topic, ns: topic == '/world/cleaning'
                             and at(7.5) < ns < at(8.5)},
                            'cue_maps', 'the first at t = 8 s'),
    'lost_robot_states': ({'drop': lambda topic, ns: topic == '/world/robot_states'
                           and at(4.5) < ns < at(5.5)},
                          'robot_states', '1 of 21 sampled times (t = 0 and each recorded '
                                          'pose) have no states, the first at t = 5'),
    'no_sources_at_t0': ({'drop': lambda topic, ns: topic == '/world/sources' and ns == at(0)},
                         'sources', 'no /world/sources at t = 0 (the first at t = 2'),
}


def mona_swarm(*args: str | Path, env: dict[str, str] | None = None
               ) -> subprocess.CompletedProcess:
    return subprocess.run([MONA_SWARM, *map(str, args)], capture_output=True, text=True,
                          timeout=300, env=env)


def record(folder: Path) -> dict:
    return json.loads((folder / 'episode.json').read_text())


@pytest.fixture(scope='module')
def bags(tmp_path_factory) -> dict[str, Path]:
    """A complete bag and one of each kind of damage, all of the same episode."""
    root = tmp_path_factory.mktemp('completeness')
    paths = {'complete': root / 'complete' / 'bag'}
    embedded_episode_bag(paths['complete'], CONFIG)
    for name, (options, _, _) in DAMAGE.items():
        paths[name] = root / name / 'bag'
        embedded_episode_bag(paths[name], CONFIG, **options)
    return paths


# --- whole bags -----------------------------------------------------------------------------

def test_complete_bag_passes_every_check(bags, tmp_path):
    result, findings = completeness.check_bag(read_episode_bag(bags['complete']))
    assert findings == [] and result.cue_maps_checked == 11 and len(result.rows) == 21
    run = mona_swarm('analyze', bags['complete'], '--out', tmp_path / 'out')
    assert run.returncode == 0, run.stderr
    assert 'online metrics agree to 0; 11 cue maps match the rebuilt cue to 0' in run.stdout
    assert 'INCOMPLETE' not in run.stdout and run.stderr == ''
    written = record(tmp_path / 'out')
    assert written['complete'] is True and written['completeness'] == []
    assert written['runner'] == 'ros' and 'wall_time_s' not in written  # written once, trimmed


def test_the_damage_is_real(bags):
    """Each damaged bag lacks what its name says (else the tests below prove nothing)."""
    complete = read_episode_bag(bags['complete'])
    assert complete.status[-1][1]['state'] == 'finished'
    assert read_episode_bag(bags['not_finished']).status[-1][1]['state'] == 'running'
    lost = read_episode_bag(bags['lost_cleaning_event'])
    assert len(lost.cleaning) == len(complete.cleaning) - 1
    assert len(lost.poses) == len(complete.poses)
    assert read_episode_bag(bags['first_seconds']).poses[0][0] >= at(5)


@pytest.mark.parametrize('name', list(DAMAGE))
def test_analyze_refuses_an_incomplete_bag_and_allow_incomplete_records_why(bags, tmp_path,
                                                                            name):
    _, check, text = DAMAGE[name]
    refused = mona_swarm('analyze', bags[name], '--out', tmp_path / 'refused')
    assert refused.returncode == 1, refused.stdout + refused.stderr
    assert f'{bags[name]}/bag.mcap is incomplete' in refused.stderr
    assert f'{check} (' in refused.stderr and text in refused.stderr
    assert '--allow-incomplete' in refused.stderr and 'Traceback' not in refused.stderr
    assert not (tmp_path / 'refused' / 'episode.json').exists()  # nothing wrong is written

    accepted = mona_swarm('analyze', bags[name], '--out', tmp_path / 'accepted',
                          '--allow-incomplete')
    assert accepted.returncode == 0, accepted.stderr
    assert 'INCOMPLETE: fails' in accepted.stdout and text in accepted.stdout
    written = record(tmp_path / 'accepted')
    assert written['complete'] is False
    findings = [Finding.from_dict(item) for item in written['completeness']]
    assert any(f.check == check and text in f.detail for f in findings), findings
    assert (tmp_path / 'accepted' / 'metrics.csv').exists()
    failed = checks.failed_checks(findings)
    if name == 'not_finished':
        assert failed == ['finished']  # nothing else is wrong with that bag
    if name == 'lost_cleaning_event':
        assert 'samples' not in failed and 'finished' not in failed
    if name in ('lost_robot_states', 'no_sources_at_t0'):
        assert failed == [check]  # the metrics are whole


def test_a_bag_without_its_announcement_cannot_be_analysed(tmp_path):
    bag = tmp_path / 'bag'
    embedded_episode_bag(bag, CONFIG.replace(episode={'duration': 3.0}),
                         drop=lambda topic, ns: topic == '/episode')
    for options in ((), ('--allow-incomplete',)):
        run = mona_swarm('analyze', bag, '--out', tmp_path / 'out', *options)
        assert run.returncode == 1, run.stderr
        assert 'fails the announcement check' in run.stderr
        assert 'holds no /episode announcement' in run.stderr
    assert not (tmp_path / 'out').exists()


def test_study_from_episodes_refuses_incomplete_episodes(bags, tmp_path):
    episodes = tmp_path / 'episodes'
    assert mona_swarm('analyze', bags['complete'], '--out', episodes / 'seed1').returncode == 0
    other = tmp_path / 'seed2' / 'bag'  # another seed: a study never holds one episode twice
    embedded_episode_bag(other, CONFIG.replace(episode={'seed': 2}),
                         drop=DAMAGE['middle_gap'][0]['drop'])
    analysed = mona_swarm('analyze', other, '--out', episodes / 'seed2', '--allow-incomplete')
    assert analysed.returncode == 0, analysed.stderr

    refused = mona_swarm('study', '--from-episodes', episodes, '--out', tmp_path / 'refused')
    assert refused.returncode == 1, refused.stderr
    assert '1 of 2 episodes are incomplete' in refused.stderr
    assert f'{episodes / "seed2"}:' in refused.stderr and 'seed1' not in refused.stderr
    assert 'the first at t = 10 s' in refused.stderr
    assert not (tmp_path / 'refused' / 'report.md').exists()

    accepted = mona_swarm('study', '--from-episodes', episodes, '--out', tmp_path / 'study',
                          '--allow-incomplete')
    assert accepted.returncode == 0, accepted.stderr
    assert '(1 incomplete, listed in the report)' in accepted.stdout
    report = (tmp_path / 'study' / 'report.md').read_text()
    assert '1 of 2 episodes are incomplete' in report
    listed = [line for line in report.splitlines() if line.startswith('  - `seed2`')]
    assert len(listed) == 1 and 'samples (' in listed[0] and 'missing t = 10-12 s' in listed[0]
    assert '`seed1`' not in report


def test_study_checks_metrics_csv_itself(bags, tmp_path):
    """A folder whose episode.json claims nothing is missing still has its rows checked."""
    folder = tmp_path / 'episodes' / 'seed1'
    assert mona_swarm('analyze', bags['complete'], '--out', folder).returncode == 0
    lines = (folder / 'metrics.csv').read_text().splitlines(keepends=True)
    (folder / 'metrics.csv').write_text(''.join(lines[:6] + lines[9:]))  # drop t = 5, 6, 7
    findings = study.episode_findings(folder)
    assert [(f.check, f.where) for f in findings] == [('samples', 'metrics.csv')]
    assert '3 of 21' in findings[0].detail and 'the first at t = 5 s' in findings[0].detail


def test_allow_incomplete_is_for_from_episodes_only(tmp_path, capsys):
    assert main(['study', '--out', str(tmp_path / 'study'), '--allow-incomplete']) == 2
    assert '--allow-incomplete applies to --from-episodes only' in capsys.readouterr().err
    assert not (tmp_path / 'study').exists()  # refused before running anything


@pytest.mark.ros
def test_replay_refuses_an_incomplete_bag_unless_allowed(bags, ros_env):
    refused = mona_swarm('replay', bags['not_finished'], '--pace', '0', '--delay', '0',
                         env=ros_env)
    assert refused.returncode == 1, refused.stderr
    assert 'fails the finished check' in refused.stderr and 'replayed' not in refused.stdout
    accepted = mona_swarm('replay', bags['not_finished'], '--pace', '0', '--delay', '0',
                          '--allow-incomplete', env=ros_env)
    assert accepted.returncode == 0, accepted.stderr
    assert 'replayed' in accepted.stdout
    assert 'warning:' in accepted.stderr and 'fails the finished check' in accepted.stderr


# --- the checks on synthetic data -----------------------------------------------------------

def rows(*times: float) -> list[dict[str, float]]:
    return [{'t': t} for t in times]


def test_rows_from_zero_to_the_duration_pass():
    assert checks.check_rows(rows(*range(21)), 20.0, 1.0) == []
    assert checks.check_rows(rows(*range(22)), 20.5, 1.0) == []  # t = 21 > 20.5: extra
    half = rows(*(k * 0.5 for k in range(9)))
    assert checks.check_rows(half, 4.0, 0.5) == []


def test_missing_first_seconds_name_the_first_missing_second_and_the_count():
    [finding] = checks.check_rows(rows(0, *range(16, 21)), 20.0, 1.0)
    assert (finding.check, finding.where) == ('samples', checks.RECOMPUTED)
    assert finding.detail == ('15 of 21 samples (every 1 s from t = 0 to 20 s) are missing, '
                              'the first at t = 1 s (missing t = 1-15 s)')
    [finding] = checks.check_rows(rows(*range(16, 21)), 20.0, 1.0)
    assert 'the first at t = 0 s (missing t = 0-15 s)' in finding.detail


def test_gaps_and_an_early_end_are_found():
    [finding] = checks.check_rows(rows(0, 1, 3, 4, 7, 8), 10.0, 1.0)
    assert finding.detail.startswith('5 of 11 samples')
    assert 'missing t = 2, 5-6, 9-10 s' in finding.detail
    many = rows(*range(0, 21, 2))  # every other second: 10 gaps, 4 listed
    assert checks.check_rows(many, 20.0, 1.0)[0].detail.endswith(
        'missing t = 1, 3, 5, 7, ... s)')
    [finding] = checks.check_rows(rows(0, 0.5, 1.5), 2.0, 0.5)
    assert 'missing t = 1, 2 s' in finding.detail and '2 of 5 samples' in finding.detail
    assert checks.check_rows([], 2.0, 1.0)[0].detail.startswith('3 of 3')


def test_online_samples_count_only_when_every_metric_has_them():
    sample = 10**9
    full = {name: [(5 + k * sample, 1.0) for k in range(4)] for name in metric_names()}
    assert checks.check_online(full, 5, 3.0, 1.0) == []
    assert checks.check_online({}, 5, 3.0, 1.0) == []  # none recorded: nothing to check
    full['coherency'] = full['coherency'][:2] + full['coherency'][3:]  # t = 2 lost
    [finding] = checks.check_online(full, 5, 3.0, 1.0)
    assert finding.where == checks.ONLINE
    assert '1 of 4 samples' in finding.detail and 'the first at t = 2 s' in finding.detail
    off_grid = {name: [(5 + k * sample + 1, 1.0) for k in range(4)]
                for name in metric_names()}  # 1 ns late: not at a boundary
    assert '4 of 4 samples' in checks.check_online(off_grid, 5, 3.0, 1.0)[0].detail


def test_finished_status_of_this_episode_is_required():
    running = (3 * 10**9, {'episode': 1, 'state': 'running'})
    finished = (4 * 10**9, {'episode': 1, 'state': 'finished'})
    assert checks.check_finished([running, finished], 1) == []
    [finding] = checks.check_finished([running], 1, start_ns=10**9)
    assert finding.check == 'finished' and finding.where == '/world/status'
    assert "the last is 'running' at t = 2 s" in finding.detail
    assert 'none of the 2 recorded is for this episode' in \
        checks.check_finished([running, finished], 0)[0].detail
    failed = (5 * 10**9, {'episode': 1, 'state': 'failed', 'error': 'robot 3 silent'})
    assert '(error: robot 3 silent)' in checks.check_finished([running, failed], 1)[0].detail


def test_cue_maps_must_match_exactly():
    assert checks.check_cue_maps(6, 0) == []
    [finding] = checks.check_cue_maps(6, 56, 2, 18.0, 'literal')
    assert (finding.check, finding.where) == ('cue_maps', '/world/cue_map')
    assert '2 of 6 recorded cue maps' in finding.detail and 'up to 56' in finding.detail
    assert 'the first at t = 18 s' in finding.detail
    assert 'no cue map recorded' in checks.check_cue_maps(0, 0)[0].detail
    assert checks.check_cue_maps(6, 56, cleaning='stochastic') == []  # not rebuildable


def test_online_metrics_must_equal_the_recomputation():
    assert checks.check_online_metrics(None) == []
    assert checks.check_online_metrics(0.0) == []
    [finding] = checks.check_online_metrics(1e-12, ('coherency', 3.0))
    assert finding.where == '/metrics/coherency' and 'up to 1e-12' in finding.detail
    assert 'the first at t = 3 s' in finding.detail
    assert 'a NaN on one side only' in checks.check_online_metrics(math.inf)[0].detail


def test_findings_round_trip_and_are_ordered_by_check():
    findings = [Finding('cue_maps', 'a', 'x'), Finding('finished', 'b', 'y'),
                Finding('cue_maps', 'c', 'z')]
    assert [Finding.from_dict(f.to_dict()) for f in findings] == findings
    assert checks.failed_checks(findings) == ['finished', 'cue_maps']
    assert str(findings[1]) == 'finished (b): y'
    with pytest.raises(ValueError):
        Finding.from_dict({'check': 'samples'})


def test_sources_must_be_where_the_announced_parameters_put_them():
    world = WorldParams(sources={'a': [1.0, 1.0, 0.3, 255.0]},
                        source_velocity={'a': [0.01, 0.0]})
    where = checks.announced_sources(world)
    recorded = [(at(t), where(t)) for t in (0.0, 10.0, 20.0)]
    assert checks.check_sources(recorded, where, START_NS) == []
    assert where(10.0)[0][1:] == pytest.approx((1.1, 1.0))  # it moves at 1 cm/s
    # A message of another time (a stale latched one) or a source that did not move.
    stale = [recorded[0], (at(10.0), where(0.0)), recorded[2]]
    (finding,) = checks.check_sources(stale, where, START_NS)
    assert finding.check == 'sources' and '1 of 3' in finding.detail
    assert 'the first at t = 10 s' in finding.detail
    assert checks.check_sources([], where, START_NS)[0].detail.endswith('none recorded)')


def test_robot_states_need_one_known_code_per_robot():
    pose_times = [at(1.0), at(2.0)]
    good = [(at(t), [0, 2, 3]) for t in (0.0, 1.0, 2.0)]
    assert checks.check_states(good, pose_times, START_NS, 3, 4) == []
    (short,) = checks.check_states(good[:1] + [(at(1.0), [0, 2])] + good[2:],
                                         pose_times, START_NS, 3, 4)
    assert 'at t = 1 s are [0, 2]: expected 3 codes below 4' in short.detail
    (unknown,) = checks.check_states(good[:2] + [(at(2.0), [0, 9, 1])], pose_times,
                                           START_NS, 3, 4)
    assert '[0, 9, 1]' in unknown.detail
    # The kind's states say which codes are known: a kind with three has no code 3.
    (beyond,) = checks.check_states(good, pose_times, START_NS, 3, 3)
    assert 'expected 3 codes below 3' in beyond.detail
    (missing,) = checks.check_states(good[1:], pose_times, START_NS, 3, 4)
    assert 'the first at t = 0 s' in missing.detail
