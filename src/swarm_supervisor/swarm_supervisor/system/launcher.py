"""The node system as real processes: what ``mona-swarm launch`` (``scripts/swarm.sh``) runs.

One world, one metrics node, the controllers (K robots per process) and the supervisor, each in
its own process group in a private ROS domain, all with the one parameter file plus the run's
overrides, which are checked with the schema before anything starts. The run waits for the
supervisor, makes sure every node ends, gives the verdict node by node on stderr, then judges
every episode's bag with the completeness verdict ``analyze`` uses (:mod:`.records`). Exit
status: 0 success, 1 a node failed or had to be stopped or a bag is incomplete, 2 a bad
option or parameter, 124 ``--timeout``, 130 / 143 SIGINT / SIGTERM. docs/running.md has the
details.

Across machines, each host runs a part: ``--role core`` (world, metrics, supervisor) on one,
``--role controllers --robots 0-24`` on others, all with the same ``--domain`` and a
``--peers`` list of the hosts' addresses, from which the launcher writes a unicast Fast DDS
profile (the loopback profile stays the default).
"""

from __future__ import annotations

import argparse
import os
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import cast

from mona_controller.schema import ParameterError
from swarm_supervisor import exits
from swarm_supervisor.engine.inputs import check_inputs
from swarm_supervisor.outputs.guard import RecordExists
from swarm_supervisor.system.node_commands import ROLES, node_commands
from swarm_supervisor.system.out_folder import claim_out, default_out
from swarm_supervisor.system.preflight import (
    EXECUTABLES,
    UsageError,
    check_fit,
    check_parameters,
    check_participants,
    check_port,
    check_profile,
    check_roles,
    config_file,
    find_executable,
    forced_domain,
    run_overrides,
)
from swarm_supervisor.system.processes import (
    LIVE_READY,
    claim_domain,
    default_profile,
    describe,
    groups_shm,
    local_address,
    peers_profile,
    remove_shm_leftovers,
    ros_environment,
    start_group,
    stop_groups,
    wait_for_log,
    wait_gone,
)
from swarm_supervisor.system.progress import ProgressLine, read_progress
from swarm_supervisor.system.records import incomplete_records

PROG = 'mona-swarm launch'
#: Seconds the nodes get to end by themselves after the supervisor's shutdown announcement.
SHUTDOWN_GRACE = 30.0
#: Seconds the metrics node gets to notice a dead world and close its bag.
BAG_GRACE = 30.0
#: Seconds a world or metrics node may have ended cleanly before the supervisor does: as long
#: as the nodes get after the shutdown announcement (10 s was too short on a busy machine: a
#: metrics node that ended on the announcement failed a node-system run that had finished).
QUIET_END = 30.0
#: Seconds between two looks at the /dev/shm files the nodes map.
NOTE_SHM_EVERY = 10.0
#: Wall seconds between two progress lines on stderr.
PROGRESS_EVERY = 10.0
#: The file a ``--peers`` run writes its Fast DDS profile to, in the output folder.
PEERS_PROFILE = 'fastdds_peers.xml'


def say(message: str) -> None:
    """One line of the launcher's own on stderr."""
    print(f'{PROG}: {message}', file=sys.stderr, flush=True)


def last_error(log: Path) -> str:
    """The message of the last [ERROR] or [FATAL] line of a node's log, or ''."""
    try:
        lines = log.read_text(errors='replace').splitlines()
    except OSError:
        return ''
    errors = [line for line in lines if line.startswith(('[ERROR]', '[FATAL]'))]
    return errors[-1].split(']: ', 1)[-1] if errors else ''


def write_ros_env(path: Path, env: dict[str, str]) -> None:
    """ros_env.sh: source it to reach the run from another shell."""
    lines = ['# source this file to reach the run from another shell (ros2 topic echo, rviz2, '
             '...)']
    for key in ('ROS_DOMAIN_ID', 'RMW_IMPLEMENTATION', 'FASTRTPS_DEFAULT_PROFILES_FILE'):
        lines.append(f'export {key}={shlex.quote(env[key])}')
    lines.append('unset ROS_AUTOMATIC_DISCOVERY_RANGE ROS_LOCALHOST_ONLY ROS_STATIC_PEERS')
    path.write_text('\n'.join(lines) + '\n')


class Run:
    """The node processes of one run, by name, and how each of them ended."""

    def __init__(self, out: Path, env: dict[str, str], domain: int,
                 pass_fds: tuple[int, ...], timeout: int = 0) -> None:
        self.out = out
        self.timeout = timeout
        self.env = env
        self.domain = domain
        self.pass_fds = pass_fds
        self.nodes: dict[str, subprocess.Popen] = {}
        self.stopping = ''  # the name of the signal that asked us to stop
        self.needed: dict[int, signal.Signals] = {}  # pid -> last signal of the stop ladder
        self.seen_shm: set[str] = set()
        self.lingering = False  # the run is over and the live node serves its final state
        (out / 'processes.tsv').write_text('')

    def catch(self, sig: int, frame: object) -> None:
        """Signal handler: remember that we were asked to stop."""
        self.stopping = signal.Signals(sig).name

    def interrupted(self) -> bool:
        """True once a signal asked the run to stop."""
        return bool(self.stopping)

    def start(self, name: str, command: list[str]) -> None:
        """Start a node (its own process group, logs/<name>.log) and list it in processes.tsv.
        It inherits the domain's lock: the domain stays taken while any node lives."""
        process = start_group(command, self.out / 'logs' / f'{name}.log', self.env,
                              self.pass_fds, on_parent_death=signal.SIGINT)
        self.nodes[name] = process
        with open(self.out / 'processes.tsv', 'a') as table:
            table.write(f'{name}\t{process.pid}\t{" ".join(command)}\n')

    def live(self) -> list[subprocess.Popen]:
        """The started processes still running."""
        return [process for process in self.nodes.values() if process.poll() is None]

    def note_shm(self, stop: Callable[[], bool] = lambda: False) -> None:
        """Remember the Fast DDS /dev/shm files the nodes map (a killed one cannot tell); give
        up early once ``stop()`` holds."""
        self.seen_shm |= groups_shm([process.pid for process in self.live()], stop)

    def wait(self) -> str:
        """Wait for the supervisor: 'finished' or 'failed' with it, 'failed' when the world or
        the metrics node ends first, 'timeout', or '' when a signal came. A controller that
        dies is the world's business (it counts the misses) and fails the run later.

        Without a supervisor here (``--role controllers``) the run is over when every node
        has ended ('finished'): controllers end on the supervisor's shutdown announcement,
        wherever the supervisor runs.
        """
        started = noted = shown = time.monotonic()
        progress = ProgressLine()
        clean_end: dict[str, float] = {}
        while not self.stopping:
            time.sleep(0.5)
            if 'supervisor' not in self.nodes and not self.live():
                return 'finished'
            status = self.nodes['supervisor'].poll() if 'supervisor' in self.nodes else None
            if status is not None:
                return 'finished' if status == 0 else 'failed'
            now = time.monotonic()
            for name in ('world', 'metrics'):  # a clean end comes with the supervisor's
                if name not in self.nodes:
                    continue
                status = self.nodes[name].poll()
                if status is None:
                    continue
                clean_end.setdefault(name, now)
                if status != 0 or now - clean_end[name] > QUIET_END:
                    say(f'{name} ended ({describe(status)}) during the run: stopping the run')
                    return 'failed'
            if now - shown >= PROGRESS_EVERY and 'supervisor' in self.nodes:
                say(progress.line(read_progress(self.out), now - started))
                shown = now
            if now - noted >= NOTE_SHM_EVERY:  # a signal cuts it short: stop() notes again
                self.note_shm(self.interrupted)
                noted = now
            if self.timeout and now - started > self.timeout:
                say(f'no result after the --timeout of {self.timeout} s: stopping the run')
                return 'timeout'
        return ''

    def wind_down(self, outcome: str, linger: float | None = 0.0) -> None:
        """Give the nodes their chance to end by themselves (a signal cuts it short); after a
        finished run, let the live node serve its final state for ``linger`` s (None: until
        a signal)."""
        if outcome == 'finished':
            # After the shutdown announcement the nodes end by themselves; give them time to.
            live = self.nodes.get('live')
            wait_gone([p for p in self.live() if p is not live], SHUTDOWN_GRACE,
                      self.interrupted)
            if live is not None and linger != 0 and live.poll() is None \
                    and not self.stopping:
                self.lingering = True
                say(f'the run is done ({self.out}); the live view keeps serving its final '
                    'state ' + ('until Ctrl-C' if linger is None else
                                f'for {linger:g} s or until Ctrl-C'))
                wait_gone([live], 1e9 if linger is None else linger + SHUTDOWN_GRACE,
                          self.interrupted)
            else:
                wait_gone([live] if live is not None else [], SHUTDOWN_GRACE,
                          self.interrupted)
        elif outcome == 'failed' and 'world' in self.nodes \
                and self.nodes['world'].poll() is not None \
                and self.nodes['metrics'].poll() is None:
            say(f'waiting up to {BAG_GRACE:g} s for the metrics node to notice and close its bag')
            wait_gone([self.nodes['metrics']], BAG_GRACE, self.interrupted)

    def stop(self) -> None:
        """Stop every node still running with the signal ladder, then remove our /dev/shm
        leftovers: our domain's port files and the files our nodes mapped, unless in use."""
        self.needed.update(stop_groups(list(self.nodes.values()), say=say,
                                       signalled=self.note_shm))
        remove_shm_leftovers(self.domain, self.seen_shm)

    def verdict(self, outcome: str) -> int:
        """Name every node that failed on stderr; return how many did."""
        failures = 0
        for name, process in self.nodes.items():
            what = f'{name} (pid {process.pid})'
            log = self.out / 'logs' / f'{name}.log'
            needed = self.needed.get(process.pid)
            if needed is not None and needed != signal.SIGINT:
                say(f'FAILED {what}: did not stop on SIGINT, ended by {needed.name}; see {log}')
            elif needed is not None:
                # Stopped by us: fine after a signal or another node's failure. After a
                # finished run it should have ended by itself on the shutdown announcement;
                # one that had to be stopped may not have closed its outputs.
                if outcome != 'finished' or (name == 'live' and self.lingering):
                    continue  # (a lingering live view is stopped by Ctrl-C: its way to end)
                say(f'FAILED {what}: did not end by itself after the shutdown; stopped by '
                    f'SIGINT; see {log}')
            elif process.returncode != 0:
                say(f'FAILED {what}: {describe(process.returncode)}; see {log}')
                reason = last_error(log)
                if reason:
                    say(f'  its last error: {reason}')
            else:
                continue
            failures += 1
        return failures


class ChecksTerminated(BaseException):
    """A SIGTERM came while the launcher checked its options (nothing had started).

    A BaseException, as KeyboardInterrupt: what catches a user's metric's errors lets it
    through."""


def _terminate_checks(sig: int, frame: object) -> None:
    raise ChecksTerminated


def launch(options: argparse.Namespace) -> int:
    """Run the node system of ``options`` (``mona-swarm launch``); returns the exit status
    (:mod:`swarm_supervisor.exits`)."""
    caught: list[str] = []  # a SIGTERM after the checks, before the run's own handler
    signal.signal(signal.SIGTERM, _terminate_checks)  # during the checks: stop them at once
    try:
        try:
            profile = os.environ.get('SWARM_FASTDDS_PROFILE') or str(default_profile())
            executables = {kind: find_executable(*where) for kind, where in EXECUTABLES.items()}
            config = check_parameters(config_file(options), run_overrides(options))
            check_roles(options, config.episode.population)
            if getattr(options, 'linger', None) is not None and not options.live:
                raise UsageError('--linger is for --live: it keeps the live view up after the run')
            domain = options.domain if options.domain is not None else forced_domain()
            if options.role != 'all' and domain is None:
                raise UsageError(f'--role {options.role}: give --domain ID (the same on every '
                                 'host), so that the hosts of the run find each other')
            if 'supervisor' in ROLES[options.role]:  # the supervisor places the robots
                check_fit(config, options.episodes,
                          '--population' if options.population is not None else
                          'episode.population')
            if 'world' in ROLES[options.role]:  # its cue file, the metrics of its first state
                check_inputs(config)
            check_participants(options, config.episode.population, domain)
            if options.live:  # the live node would fail after the whole run
                check_port(options.live_port, '--live-port')
            check_profile(os.environ.get('SWARM_FASTDDS_PROFILE'))
            address = local_address(options.peers) if options.peers else None
            if options.peers and address is None:
                raise UsageError(f'--peers {",".join(options.peers)}: none is an address of this '
                                 "host; list every host's address, this one's too")
        finally:  # from here on a SIGTERM is remembered: start nothing, end 143
            signal.signal(signal.SIGTERM, lambda sig, frame: caught.append('SIGTERM'))
    except ChecksTerminated:  # under load the checks can take many seconds of a busy core
        say('SIGTERM received during the checks: nothing started')
        return exits.TERMINATED
    except UsageError as error:
        say(str(error))
        return exits.USAGE
    except ParameterError as error:
        say(f'bad parameter: {error}')
        return exits.USAGE
    except KeyboardInterrupt:  # Ctrl-C during the checks: nothing started, no traceback
        return exits.INTERRUPTED
    out = options.out or default_out()
    try:
        claim_out(out, getattr(options, 'overwrite', False))
        (out / 'logs').mkdir(parents=True, exist_ok=True)
    except (RecordExists, ParameterError) as error:  # a record, a writer, a bad place
        say(str(error))
        return exits.USAGE
    except OSError as error:
        say(f"cannot create '{out / 'logs'}': {error.strerror or error}")
        return exits.USAGE
    out = out.resolve()
    lock = None
    if domain is None:
        try:
            domain, lock = claim_domain()
        except RuntimeError as error:
            say(str(error))
            return exits.USAGE

    if options.peers:
        profile = str(out / PEERS_PROFILE)
        Path(profile).write_text(peers_profile(cast(str, address), options.peers))
    env = ros_environment(domain, Path(profile), log_dir=out / 'logs' / 'ros')
    write_ros_env(out / 'ros_env.sh', env)
    run = Run(out, env, domain, (lock.fileno(),) if lock else (), options.timeout)
    run.stopping = ''.join(caught[-1:])
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, run.catch)
    population = config.episode.population
    part = '' if options.role == 'all' else f', role {options.role}'
    network = f', peers {",".join(options.peers)} (here {address})' if options.peers else ''
    say(f'domain {domain}, {population} robots, {options.episodes} episode(s), '
        f'{options.mode}{part}{network}, output {out}')
    if options.live:
        say(f'live view: ws://localhost:{options.live_port} (Foxglove: Open connection, '
            'Foxglove WebSocket)')
    outcome = ''
    try:
        for name, command in node_commands(options, population, out, executables).items():
            if name == 'supervisor' and 'live' in run.nodes:  # no episode before the live view
                wait_for_log(run.nodes['live'], out / 'logs' / 'live.log', LIVE_READY,
                             options.start_timeout or 60, run.interrupted)
            if run.stopping:  # a signal while spawning: start no more, stop what started
                break
            run.start(name, command)
        outcome = run.wait()
        if run.stopping:
            say(f'{run.stopping} received: stopping every node')
        run.wind_down(outcome, getattr(options, 'linger', 0.0) if options.live else 0.0)
    finally:  # also on an unexpected error here: no node outlives the run
        run.stop()
    failures = run.verdict(outcome)
    if outcome == 'finished':
        # Exit 0 only with bags that analyze accepts: judged with its function, on disk.
        records = incomplete_records(out) if 'supervisor' in run.nodes else []
        for problem in records:
            say(f'FAILED record {problem}')
        if failures or records:
            return exits.FAILED
        say(f'done: {out}')
        return exits.OK
    if outcome in ('failed', 'timeout'):
        return exits.FAILED if outcome == 'failed' else exits.TIMEOUT
    return exits.INTERRUPTED if run.stopping == 'SIGINT' else exits.TERMINATED
