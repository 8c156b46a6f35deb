"""The launcher of the node system without ROS: options, overrides, controller processes, the
domain lock and the signal ladder (swarm_supervisor.system.launcher and .processes)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mona_controller.schema import ParameterError
from swarm_supervisor.cli import launch as launch_cli
from swarm_supervisor.cli import main
from swarm_supervisor.config import DEFAULT_CONFIG
from swarm_supervisor.system import launcher
from swarm_supervisor.system.node_commands import controller_groups, node_commands
from swarm_supervisor.system.processes import (
    claim_domain,
    group_pids,
    lock_domain,
    ros_environment,
    start_group,
    stop_group,
    stop_groups,
)


def options(*argv: str):
    return launch_cli.build_parser().parse_args(list(argv))


def test_defaults():
    parsed = options()
    assert (parsed.episodes, parsed.mode, parsed.per_process, parsed.timeout) == \
        (1, 'lockstep', 1, 0)
    assert parsed.config is None and parsed.params == []  # the shipped file, found at launch
    assert parsed.population is None and parsed.start_timeout is None


@pytest.mark.parametrize('argv, option', [
    (['--population', 'x'], '--population'),
    (['--population', '-1'], '--population'),
    (['--speed', 'fast'], '--speed'),
    (['--episodes', '0'], '--episodes'),
    (['--duration', 'nan'], '--duration'),
    (['--seed', '1.5'], '--seed'),
    (['--mode', 'fast'], '--mode'),
    (['--config', '/no/such.yaml'], '--config'),
    (['--controllers-per-process', '0'], '--controllers-per-process'),
    (['--timeout', '2.5'], '--timeout'),
    (['--start-timeout', '0'], '--start-timeout'),
    (['-p', 'controller.speed=0.1'], '-p'),
    (['--popul', '3'], '--popul'),  # no abbreviations: every option is spelled out
    (['--timeout'], '--timeout'),
])
def test_a_bad_option_is_named(argv, option, capsys):
    with pytest.raises(SystemExit) as stopped:
        main(['launch', *argv])
    assert stopped.value.code == 2
    error = capsys.readouterr().err.splitlines()[-1]
    assert error.startswith('mona-swarm') and ': error: ' in error and option in error


def test_overrides_come_from_the_options_then_p():
    parsed = options('--population', '5', '--speed', '8', '--duration', '60', '--seed', '3',
                     '-p', 'lockstep_deadline:=0.5', '-p', 'controller.beeclust.alpha:=2.0')
    assert launcher.run_overrides(parsed) == [
        'episode.population:=5', 'episode.duration:=60.0', 'episode.seed:=3',
        'controller.speed:=0.08', 'lockstep_deadline:=0.5', 'controller.beeclust.alpha:=2.0']


def test_overrides_are_checked_with_the_schema():
    config = launcher.check_parameters(DEFAULT_CONFIG, [
        'episode.population:=7', 'controller.speed:=0.04', 'lockstep_deadline:=0.5'])
    assert (config.episode.population, config.controller.speed) == (7, 0.04)
    with pytest.raises(ParameterError, match=r'controller.speed = 3.0 is out of range'):
        launcher.check_parameters(DEFAULT_CONFIG, ['controller.speed:=3.0'])
    with pytest.raises(ParameterError, match='controller.nope'):
        launcher.check_parameters(DEFAULT_CONFIG, ['controller.nope:=1'])
    with pytest.raises(ParameterError, match='episode.population = 0'):
        launcher.check_parameters(DEFAULT_CONFIG, ['episode.population:=0'])
    with pytest.raises(ParameterError, match='episode.seed'):
        launcher.check_parameters(DEFAULT_CONFIG, ['episode.seed:=[1'])


def test_a_bad_parameter_exits_2_before_anything_starts(tmp_path: Path, capsys):
    out = tmp_path / 'never'
    assert main(['launch', '--speed', '300', '--out', str(out)]) == 2
    assert 'mona-swarm launch: bad parameter: controller.speed = 3.0 is out of range' in \
        capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize('population, per_process, groups', [
    (5, 1, ['0', '1', '2', '3', '4']),
    (10, 4, ['0-3', '4-7', '8-9']),
    (3, 5, ['0-2']),
    (7, 3, ['0-2', '3-5', '6']),
    (1, 1, ['0']),
])
def test_controller_groups(population, per_process, groups):
    assert controller_groups(population, per_process) == groups


def test_each_node_gets_the_parameters_and_its_own_options():
    parsed = options('--population', '3', '--episodes', '2', '--controllers-per-process', '2',
                     '-p', 'clock_period:=1.0')
    out = Path('/results/run')
    executables = {kind: f'/bin/{kind}' for kind in launcher.EXECUTABLES}
    commands = node_commands(parsed, 3, out, executables)
    assert list(commands) == ['world', 'metrics', 'controller_0-1', 'controller_2',
                              'supervisor']
    common = ['--ros-args', '--params-file', str(DEFAULT_CONFIG),
              '-p', 'episode.population:=3', '-p', 'clock_period:=1.0']
    assert commands['world'] == ['/bin/world', *common, '-p', 'mode:=lockstep',
                                 '-p', f'output_dir:={out}', '-p', 'start_timeout:=60.0',
                                 '-p', 'recorders:=metrics']
    assert commands['metrics'] == ['/bin/metrics', *common, '-p', f'output_dir:={out}']
    assert commands['controller_0-1'] == ['/bin/controller', '--robots', '0-1', *common]
    assert commands['supervisor'] == ['/bin/supervisor', *common, '-p', 'episodes:=2',
                                      '-p', f'output_dir:={out}', '-p', 'recorders:=metrics']
    # With a live view the supervisor (only) waits for its word too: it holds the final state.
    live = node_commands(options('--live'), 3, out, executables)
    assert live['supervisor'][-2:] == ['-p', 'recorders:=metrics,live']
    assert live['world'][-2:] == ['-p', 'recorders:=metrics']
    # The world's patience grows with the swarm, unless given.
    many = node_commands(options('--population', '40'), 40, out, executables)
    assert 'start_timeout:=120.0' in many['world']
    given = node_commands(options('--start-timeout', '5'), 40, out, executables)
    assert 'start_timeout:=5.0' in given['world']


def test_last_error_is_the_message_of_the_last_error_line(tmp_path: Path):
    log = tmp_path / 'world.log'
    log.write_text('[ERROR] [1.0] [world]: first\n[INFO] [2.0] [world]: fine\n'
                   '[FATAL] [3.0] [world]: episode 0: the recorder(s) metrics did not confirm\n'
                   'Traceback ...\n')
    assert launcher.last_error(log) == 'episode 0: the recorder(s) metrics did not confirm'
    assert launcher.last_error(tmp_path / 'missing.log') == ''


def test_the_domain_lock_excludes_a_second_holder_and_is_inherited(tmp_path: Path):
    domain, handle = claim_domain()
    try:
        assert lock_domain(domain) is None  # a second holder, even in this process
        child = start_group([sys.executable, '-c', 'import time; time.sleep(60)'],
                            tmp_path / 'child.log', ros_environment(domain),
                            pass_fds=(handle.fileno(),))
    finally:
        handle.close()
    try:
        assert lock_domain(domain) is None  # the child holds it on
    finally:
        stop_group(child, grace=5.0)
    again = lock_domain(domain)
    assert again is not None
    again.close()


def started(tmp_path: Path, code: str, name: str = 'node') -> tuple:
    """A Python child in its own group, once it printed 'ready'; (process, its log)."""
    log = tmp_path / f'{name}.log'
    process = start_group([sys.executable, '-c', code], log, ros_environment(0))
    deadline = time.monotonic() + 60
    while 'ready' not in log.read_text():
        assert process.poll() is None and time.monotonic() < deadline, log.read_text()
        time.sleep(0.05)
    return process, log


IGNORE = ('import signal, time\n'
          'for name in {signals}: signal.signal(getattr(signal, name), signal.SIG_IGN)\n'
          'print("ready", flush=True)\n'
          'time.sleep(60)\n')


def test_the_ladder_sends_sigterm_to_a_node_that_ignores_sigint(tmp_path: Path):
    process, _ = started(tmp_path, IGNORE.format(signals=['SIGINT']))
    said: list[str] = []
    needed = stop_groups([process], grace=1.0, say=said.append)
    assert needed == {process.pid: signal.SIGTERM}
    assert process.returncode == -signal.SIGTERM
    assert said == ['SIGTERM to 1 process(es) still running 1 s after SIGINT']


def test_sigabrt_writes_the_stack_of_a_node_deaf_to_sigint_and_sigterm(tmp_path: Path):
    process, log = started(tmp_path, IGNORE.format(signals=['SIGINT', 'SIGTERM']))
    said: list[str] = []
    needed = stop_groups([process], grace=0.5, say=said.append)
    assert needed == {process.pid: signal.SIGABRT}
    assert process.returncode == -signal.SIGABRT
    assert said[-1] == ('SIGABRT to 1 process(es) still running 2 s after SIGTERM '
                        '(stacks in their logs)')
    assert 'Fatal Python error: Aborted' in log.read_text()  # PYTHONFAULTHANDLER=1


def test_the_ladder_signals_every_group_at_once_and_ends_within_ten_seconds(tmp_path: Path):
    from swarm_supervisor.system.processes import LADDER
    assert sum(wait for _, wait in LADDER) <= 10.5  # a stopped run is gone within 15 s
    # 20 nodes deaf to SIGINT (the shell and its sleep ignore it): each needs SIGTERM.
    deaf = [start_group(['sh', '-c', 'trap "" INT; sleep 60 & echo ready; wait'],
                        tmp_path / f'deaf_{k}.log', ros_environment(0)) for k in range(20)]
    deadline = time.monotonic() + 60
    while not all('ready' in (tmp_path / f'deaf_{k}.log').read_text() for k in range(20)):
        assert time.monotonic() < deadline
        time.sleep(0.05)
    began = time.monotonic()
    needed = stop_groups(deaf, grace=1.0)
    took = time.monotonic() - began
    assert set(needed.values()) == {signal.SIGTERM}
    assert took < 1.0 + 2.0, took  # one SIGINT wait and one SIGTERM wait, not one per node
    assert not any(group_pids(process.pid) for process in deaf)


def test_a_node_runs_in_its_own_group_with_sigint_and_no_core(tmp_path: Path):
    # As a background job of a script would: start it with SIGINT ignored here.
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        process = start_group(['sleep', '60'], tmp_path / 'sleep.log', ros_environment(0))
    finally:
        signal.signal(signal.SIGINT, previous)
    try:
        status = Path(f'/proc/{process.pid}/status').read_text()
        ignored = int(next(line for line in status.splitlines()
                           if line.startswith('SigIgn:')).split()[1], 16)
        assert not ignored & (1 << (signal.SIGINT - 1))
        limits = Path(f'/proc/{process.pid}/limits').read_text()
        assert next(line for line in limits.splitlines()
                    if line.startswith('Max core file size')).split()[4] == '0'
        assert group_pids(process.pid) == [process.pid]
    finally:
        assert stop_group(process) == -signal.SIGINT


def test_the_ladder_clears_a_group_whose_leader_ended(tmp_path: Path):
    # The leader ends on SIGINT; its child (started by sh in the background, SIGINT ignored)
    # would live on in the group.
    process = start_group(['sh', '-c', 'sleep 60 & echo ready; exec sleep 60'],
                          tmp_path / 'sh.log', ros_environment(0))
    deadline = time.monotonic() + 30
    while len(group_pids(process.pid)) < 2:
        assert time.monotonic() < deadline
        time.sleep(0.05)
    assert stop_groups([process], grace=5.0) == {process.pid: signal.SIGINT}
    deadline = time.monotonic() + 10
    while group_pids(process.pid):
        assert time.monotonic() < deadline, group_pids(process.pid)
        time.sleep(0.05)


#: A launcher in miniature: starts `sleep 60` as the launcher starts a node (with SIGTERM on
#: its death, or nothing), prints the sleep's pid, then waits to be killed.
STARTER = ('import signal, sys, time\n'
           'from pathlib import Path\n'
           'from swarm_supervisor.system.processes import ros_environment, start_group\n'
           'on_death = {on_death}\n'
           'node = start_group(["sleep", "60"], Path(sys.argv[1]), ros_environment(0),\n'
           '                   on_parent_death=on_death)\n'
           'print(node.pid, flush=True)\n'
           'time.sleep(60)\n')


@pytest.mark.parametrize('on_death', [signal.SIGTERM, None], ids=['SIGTERM', 'nothing'])
def test_a_node_hears_of_its_launchers_death_when_asked(tmp_path: Path, on_death):
    starter = subprocess.Popen(
        [sys.executable, '-c', STARTER.format(on_death=on_death and int(on_death)),
         str(tmp_path / 'sleep.log')], stdout=subprocess.PIPE, text=True)
    node = int(starter.stdout.readline())
    try:
        starter.kill()  # SIGKILL: no handler of the launcher runs
        starter.wait()
        deadline = time.monotonic() + 10
        while group_pids(node) and on_death is not None:
            assert time.monotonic() < deadline, 'the node outlived its launcher'
            time.sleep(0.05)
        # Without the request it runs on (was the launcher's way until 2026-12-05).
        assert bool(group_pids(node)) == (on_death is None)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(node, signal.SIGKILL)
