"""What the launcher refuses before it starts a process or writes a byte
(swarm_supervisor.system.preflight): a population the arena cannot hold, more DDS
participants than one domain holds, a bad SWARM_DOMAIN_ID."""

from __future__ import annotations

from pathlib import Path

import pytest

from swarm_supervisor.cli import launch as launch_cli
from swarm_supervisor.cli import main
from swarm_supervisor.config import DEFAULT_CONFIG, load_config
from swarm_supervisor.system import preflight
from swarm_supervisor.system.preflight import UsageError


def options(*argv: str):
    return launch_cli.build_parser().parse_args(list(argv))


def config(population: int, seed: int = 1):
    return load_config(DEFAULT_CONFIG).replace(episode={'population': population,
                                                        'seed': seed})


def test_a_population_that_fits_passes_for_every_episode():
    preflight.check_fit(config(30), episodes=3)


def test_a_population_that_cannot_fit_names_the_option_and_the_largest_that_fits():
    with pytest.raises(UsageError) as refused:
        preflight.check_fit(config(2000), episodes=1)
    message = str(refused.value)
    assert message.startswith('--population 2000 does not fit a ')
    assert 'give a smaller --population (at most ~' in message
    most = int(message.rsplit('~', 1)[1].rstrip(')'))
    preflight.check_fit(config(most), episodes=1)  # the bound is one that fits
    with pytest.raises(UsageError, match='episode.population 2000'):
        preflight.check_fit(config(2000), episodes=1, option='episode.population')


@pytest.mark.parametrize('argv, population, count', [
    ([], 10, 13),
    (['--controllers-per-process', '4'], 10, 6),
    (['--live'], 10, 14),
    (['--role', 'core', '--domain', '5'], 500, 3),
    (['--role', 'supervision', '--domain', '5'], 500, 2),
    (['--role', 'controllers', '--robots', '0-24', '--domain', '5'], 500, 25),
])
def test_participants_of_this_host(argv, population, count):
    assert preflight.participants(options(*argv), population) == count


def test_too_many_participants_name_the_smallest_controllers_per_process_that_fits():
    preflight.check_participants(options(), 117)  # 120 participants: fits
    with pytest.raises(UsageError) as refused:
        preflight.check_participants(options(), 200)
    assert str(refused.value) == (
        '200 robots at 1 per process are 203 DDS participants on this host (about 120 fit '
        'one domain): give --controllers-per-process 2')
    preflight.check_participants(options('--controllers-per-process', '2'), 200)
    with pytest.raises(UsageError, match='--controllers-per-process 3'):
        preflight.check_participants(options(), 300)


def test_the_last_domain_ids_hold_fewer_participants():
    assert preflight.domain_capacity(None) == preflight.domain_capacity(0) == 120
    assert preflight.domain_capacity(231) == 120
    assert preflight.domain_capacity(232) == 63
    preflight.check_participants(options('--domain', '232'), 60, 232)
    with pytest.raises(UsageError, match=r'103 DDS participants .*about 63 fit domain 232.*'
                                         r'--controllers-per-process 2'):
        preflight.check_participants(options('--domain', '232'), 100, 232)


@pytest.mark.parametrize('text, domain', [('', None), ('0', 0), ('232', 232)])
def test_swarm_domain_id(text, domain, monkeypatch):
    monkeypatch.setenv('SWARM_DOMAIN_ID', text)
    assert preflight.forced_domain() == domain


@pytest.mark.parametrize('text', ['x', '233', '-1', '1.5'])
def test_a_bad_swarm_domain_id_is_refused(text, monkeypatch):
    monkeypatch.setenv('SWARM_DOMAIN_ID', text)
    with pytest.raises(UsageError, match=f"SWARM_DOMAIN_ID '{text}': expected 0..232"):
        preflight.forced_domain()


@pytest.mark.parametrize('argv, pattern', [
    (['--population', '2000'], '--population 2000 does not fit'),
    (['--population', '200'], '203 DDS participants'),
    (['--population', '100', '--domain', '232'], 'about 63 fit domain 232'),
])
def test_the_launcher_refuses_before_it_writes(argv, pattern, tmp_path: Path, capsys):
    out = tmp_path / 'never'
    assert main(['launch', *argv, '--out', str(out)]) == 2
    error = capsys.readouterr().err
    assert pattern in error and error.count('\n') == 1, error
    assert not out.exists()


def earlier_node_run(folder: Path, *, run_json: bool = True) -> None:
    """What a stopped node-system run leaves: its bag, perhaps no run.json yet."""
    (folder / 'episode_0' / 'bag').mkdir(parents=True)
    (folder / 'episode_0' / 'bag' / 'metadata.yaml').write_text('rosbag2_bagfile_information:\n')
    if run_json:
        (folder / 'run.json').write_text('{}')


@pytest.mark.parametrize('run_json', [True, False])
def test_an_earlier_run_is_refused_naming_overwrite(run_json, tmp_path: Path, capsys):
    out = tmp_path / 'earlier'
    earlier_node_run(out, run_json=run_json)
    before = sorted(p.relative_to(out) for p in out.rglob('*'))
    assert main(['launch', '--population', '3', '--out', str(out)]) == 2
    error = capsys.readouterr().err
    assert 'already holds' in error and '--overwrite' in error and error.count('\n') == 1
    assert sorted(p.relative_to(out) for p in out.rglob('*')) == before


def test_overwrite_replaces_the_folder_whole(tmp_path: Path):
    from swarm_supervisor.system.out_folder import claim_out
    out = tmp_path / 'earlier'
    earlier_node_run(out, run_json=False)
    (out / 'logs').mkdir()
    (out / 'processes.tsv').write_text('world\t1\tworld_node\n')
    claim_out(out, overwrite=True)
    assert list(out.iterdir()) == []  # emptied; the folder stays, locked for the run
    # A folder without a record is used as it is.
    (tmp_path / 'plots').mkdir()
    (tmp_path / 'plots' / 'figure.png').write_bytes(b'png')
    claim_out(tmp_path / 'plots', overwrite=False)
    assert (tmp_path / 'plots' / 'figure.png').exists()


def test_the_default_output_folder_is_always_new(tmp_path: Path, monkeypatch):
    from swarm_supervisor.system import out_folder
    monkeypatch.chdir(tmp_path)
    first = out_folder.default_out()
    assert first.parent == tmp_path / 'results'
    first.mkdir(parents=True)
    second = out_folder.default_out()
    assert second != first and not second.exists()
