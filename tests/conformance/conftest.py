"""The conformance suite's run: one world-side implementation, started as a black box from one
command line, with the real controller nodes and the suite's probe, played through the
probe's scenario once per session; every rule's test then reads the record.

Options (tests/conformance/README.md):

- ``--world-cmd NAME-OR-COMMAND``: a name of implementations.IMPLEMENTATIONS (default: the
  first, ``world``) or a command line with ``{domain}``, ``{params}``, ``{population}``;
- ``--world-mode lockstep|realtime``: for a command line, which Stepping rules it follows
  (a realtime one is not given the tests marked ``lockstep``);
- ``--params FILE``: a parameter file of one's own instead of the shipped one, e.g. one whose
  ``plugins:`` name a controller kind the controller nodes run (docs/extending.md).
"""

from __future__ import annotations

import dataclasses
import math
import os
import shlex
import sys
import time
import warnings
from pathlib import Path

import pytest
import rclpy
import yaml
from rclpy.experimental.events_executor import EventsExecutor

from mona_controller.plugins import KEY as PLUGINS
from mona_controller.schema import ParameterError
from swarm_supervisor.config import load_config, write_ros_yaml

from harness import REPO, Processes, private_domain, ros_environment
from implementations import IMPLEMENTATIONS, Implementation, resolve
from probe import (
    CONTROLLED,
    POPULATION,
    Probe,
    Scenario,
    init_context,
    spin_briefly,
    stamp_of,
)

HERE = Path(__file__).resolve().parent
#: The suite's parameter file: the shipped one, every section.
PARAMS = REPO / 'ros_ws' / 'config' / 'mona_swarm.yaml'
#: The implementation the self-test breaks (and the default).
DEFAULT = next(iter(IMPLEMENTATIONS))
#: Wall seconds an implementation may take to exit after the shutdown announcement.
EXIT_TIMEOUT = 20.0


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup('conformance', 'the world-side conformance suite')
    group.addoption('--world-cmd', default=os.environ.get('CONFORMANCE_WORLD'),
                    help='implementation name or command line (env CONFORMANCE_WORLD)')
    group.addoption('--world-mode', default=None, choices=('lockstep', 'realtime'),
                    help="a command line's stepping mode (default lockstep)")
    group.addoption('--params', default=os.environ.get('CONFORMANCE_PARAMS'),
                    help='parameter file (default: the shipped one; env CONFORMANCE_PARAMS)')


def option(config: pytest.Config, name: str) -> str | None:
    """A suite option; a bare ``pytest`` from the root (``make test``) does not load this
    conftest early enough to add them: then the environment or the default."""
    fallback = {'--world-cmd': os.environ.get('CONFORMANCE_WORLD'),
                '--params': os.environ.get('CONFORMANCE_PARAMS')}.get(name)
    return config.getoption(name, default=fallback)


def parameter_file(config: pytest.Config, folder: Path) -> Path:
    """The run's parameter file: the shipped one, or ``--params`` written out whole with its
    plug-ins' and files' paths absolute (every process of the run reads the same file, from
    any directory; a bad file ends the session naming it, exit status 2)."""
    given = option(config, '--params')
    if not given:
        return PARAMS
    try:
        loaded = load_config(given)
    except ParameterError as error:
        pytest.exit(f'--params: {error}', returncode=2)
    write_ros_yaml(loaded, folder / 'params.yaml')
    return folder / 'params.yaml'


def implementation(config: pytest.Config) -> tuple[str, Implementation]:
    """The implementation the options name (the mode option applied)."""
    name, chosen = resolve(option(config, '--world-cmd'))
    mode = option(config, '--world-mode')
    return name, (dataclasses.replace(chosen, mode=mode) if mode else chosen)


#: The rules an implementation does not follow by design, per session (for the summary).
NOT_APPLICABLE = pytest.StashKey[list[str]]()


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Leave out what does not apply to the chosen implementation (not a skip: the rule is not
    this implementation's, and a skip under CI=true fails the run): the lockstep rules on a
    realtime one, the self-test on any but the default."""
    name, chosen = implementation(config)
    kept, left_out = [], []
    for item in items:
        if str(item.path).startswith(str(HERE)) and (
                chosen.mode != 'lockstep' and item.get_closest_marker('lockstep') or
                name != DEFAULT and item.get_closest_marker('selftest')):
            left_out.append(item.name)
        else:
            kept.append(item)
    items[:] = kept
    config.stash[NOT_APPLICABLE] = left_out


def pytest_report_collectionfinish(config: pytest.Config) -> str | None:
    left_out = config.stash.get(NOT_APPLICABLE, [])
    if left_out:
        name, chosen = implementation(config)
        return (f'conformance: {len(left_out)} tests not collected for {name} ({chosen.mode}): '
                'the lockstep rules and the self-test are not its own')
    return None


@dataclasses.dataclass
class Run:
    """The record of one scenario, with the lookups the rules need."""

    name: str
    implementation: Implementation
    params: dict
    probe: Probe
    scenario: Scenario
    world_exit: int | None  #: the world's exit status (None: it did not exit)
    world_log: str
    controllers_exit: int | None

    @property
    def step_ns(self) -> int:
        return self.probe.step_ns

    @property
    def mona(self) -> dict:
        return self.params['mona']

    @property
    def world(self) -> dict:
        return self.params['world']

    def episode(self, k: int) -> dict:
        """The announcement of episode ``k`` (fails the test if the scenario never got there)."""
        if k not in self.scenario.announced:
            pytest.fail(f'the scenario never announced episode {k}: {self.scenario.log}')
        return self.scenario.announced[k]

    def steps(self, k: int) -> int:
        """Episode ``k``'s step count: its duration rounded up to whole steps."""
        return math.ceil(round(self.episode(k)['duration'] * 1e9) / self.step_ns)

    def window(self, k: int) -> tuple[int, int]:
        """[start_ns, end_ns] of episode ``k``'s sim time."""
        start = self.episode(k)['start_ns']
        return start, start + self.steps(k) * self.step_ns

    def readings(self, robot: int, kind: str, k: int) -> list[tuple[float, int, object]]:
        """(received, stamp, message) of ``robot``'s ``kind`` stamped in episode ``k``."""
        low, high = self.window(k)  # step k's readings: t_k < end (the next episode's
        # step 0 may share the end's stamp)
        return [item for item in self.probe.readings.get((robot, kind), [])
                if low <= item[1] < high]

    def poses_at(self, stamp: int, last: bool = False):
        """The /world/poses of this stamp (None if none came): the first one, or with
        ``last`` the last one (an episode's final poses and the next one's step 0 may share a
        stamp)."""
        found = [poses for _, when, poses in self.probe.poses if when == stamp]
        return (found[-1] if last else found[0]) if found else None

    def poses_near(self, stamp: int):
        """The /world/poses of this stamp, else the nearest within a step (a realtime driver
        may stamp its tracked poses apart from its readings); None if none is that near."""
        exact = self.poses_at(stamp)
        if exact is not None or not self.probe.poses:
            return exact
        gap, poses = min((abs(when - stamp), poses) for _, when, poses in self.probe.poses)
        return poses if gap <= self.step_ns else None

    def poses_before(self, stamp: int, age_s: float) -> list:
        """The /world/poses of this stamp (or the nearest within a step) and those of the
        ``age_s`` seconds before it, newest first: what a reading of ``stamp`` may have seen."""
        near = self.poses_near(stamp)
        earlier = sorted(((when, poses) for _, when, poses in self.probe.poses
                          if stamp - age_s * 1e9 <= when < stamp), key=lambda pair: -pair[0])
        return ([] if near is None else [near]) + [poses for _, poses in earlier]

    def maps(self, k: int, name: str = 'cue_map') -> list:
        """Episode ``k``'s ``name`` messages (cue_map, cue_grid, markers): stamped in its window
        and received after its announcement and before the next one's (an episode's last map
        and the next one's first may share a stamp)."""
        low, high = self.window(k)
        after = self.scenario.marks.get(f'announced_{k}', 0.0)
        before = self.scenario.marks.get(f'announced_{k + 2 if k == 0 else k + 1}', math.inf)
        return [msg for when, msg in self.probe.latched[name]
                if after <= when < before and low <= stamp_of(msg) <= high]

    def statuses(self, k: int) -> list[dict]:
        """The /world/status documents of episode ``k``, in arrival order."""
        return [doc for _, doc in self.probe.status if doc.get('episode') == k]

    def final_status(self, k: int) -> dict:
        ended = [doc for doc in self.statuses(k) if doc.get('state') in ('finished', 'failed')]
        if not ended:
            pytest.fail(f'episode {k} never ended on /world/status: {self.scenario.log}\n'
                        f'{self.world_log[-2000:]}')
        return ended[-1]


def start_world(processes: Processes, template: str, domain: int, params: Path = PARAMS):
    """Start the implementation's command line; a command that cannot be started ends the
    session with a message naming what is wrong (exit status 2), not a traceback."""
    try:
        command = shlex.split(template.format(domain=domain, params=params,
                                              population=POPULATION))
    except (KeyError, IndexError, ValueError) as error:
        pytest.exit(f'--world-cmd {template!r}: {error!r}; the placeholders are {{domain}}, '
                    '{params} and {population}', returncode=2)
    if not command:
        pytest.exit('--world-cmd is empty', returncode=2)
    try:
        return processes.spawn(command, 'world')
    except OSError as error:
        pytest.exit(f'--world-cmd: cannot start {command[0]!r}: {error.strerror}',
                    returncode=2)


@pytest.fixture(scope='session')
def run(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Run:
    """Start the implementation and the controllers, play the scenario, stop everything.

    A world that runs but is never discovered (no first /world/status in 60 s, the world
    alive) is tried once more on a fresh private domain, with the first attempt's log and
    graph in the record: CI saw this once in many runs on a busy 2-core machine, the world
    logging "ready" while the probe's graph held no node of it. So is a lockstep run whose
    probe lacks some step's readings (:func:`missed_readings`), with a warning that says so:
    the world's readings writers keep the last 5 (the page's QoS) and do not wait for the
    probe, which no rule makes them do, so a probe held off the CPU that long loses what
    they sent (ci58, under load: robot 0's ground reading of one step). The inner runs
    retry the same way (inner_suite.READINGS_RULES)."""
    name, chosen = implementation(request.config)
    path = parameter_file(request.config, tmp_path_factory.mktemp('conformance'))
    params = yaml.safe_load(path.read_text())['/**']['ros__parameters']
    params.pop(PLUGINS, None)  # the probe announces the parameters alone
    played = _play(name, chosen, path, params, tmp_path_factory.mktemp('conformance'))
    missed = missed_readings(played)
    if not played.probe.status and played.world_exit is None or missed:
        first = played
        played = _play(name, chosen, path, params, tmp_path_factory.mktemp('conformance'))
        played.scenario.log[:0] = [
            f'first attempt: {"; ".join(first.scenario.log)}; the nodes the probe saw: '
            f'{first.scenario.graph.get("nodes")}; readings it missed: {missed}; '
            f'its world log: {first.world_log[-1500:]}',
            'second attempt, on a fresh private domain:']
        if missed:
            warnings.warn(f'conformance: the probe missed readings the world stepped past '
                          f'({"; ".join(missed)}): the scenario was played once more',
                          stacklevel=1)
    return played


def missed_readings(played: Run) -> list[str]:
    """What the probe of a lockstep run lacks of episode 0's readings, one step each per
    robot and kind (the rule ``test_lockstep_readings_are_stamped_start_ns_plus_k_step_ns``):
    ``'robot R ground: N of M steps'`` per incomplete series; none for a realtime world or a
    scenario that never announced episode 0."""
    if played.implementation.mode != 'lockstep' or 0 not in played.scenario.announced:
        return []
    start = played.window(0)[0]
    wanted = {start + k * played.step_ns for k in range(played.steps(0))}
    missed = []
    for robot in range(POPULATION):
        for kind in ('ground', 'proximity'):
            lost = wanted - {stamp for _, stamp, _ in played.readings(robot, kind, 0)}
            if lost:
                missed.append(f'robot {robot} {kind}: {len(lost)} of {len(wanted)} steps')
    return missed


def _play(name: str, chosen: Implementation, path: Path, params: dict, folder: Path) -> Run:
    """One attempt of the scenario on a private domain of its own."""
    with private_domain() as domain, pytest.MonkeyPatch.context() as patch:
        env = ros_environment(domain)
        for key in ('ROS_DOMAIN_ID', 'RMW_IMPLEMENTATION', 'FASTRTPS_DEFAULT_PROFILES_FILE'):
            patch.setenv(key, env[key])
        for key in ('ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_LOCALHOST_ONLY'):
            patch.delenv(key, raising=False)
        processes = Processes(env, folder)
        world = start_world(processes, chosen.command, domain, path)
        robots = f'{CONTROLLED[0]}-{CONTROLLED[-1]}'
        controllers = processes.spawn(['mona_controller_node', '--robots', robots,
                                       '--ros-args', '--params-file', str(path)],
                                      'controllers')
        # Robots 3 and 4 answer from a process of their own: not behind the probe's records.
        record = folder / 'scripted.jsonl'
        step_ns = round(params['world']['step_period'] * 1e9)
        scripted = processes.spawn(
            [sys.executable, str(HERE / 'scripted.py'), '--domain', str(domain), '--step-ns',
             str(step_ns), '--record', str(record), '--parent', str(os.getpid())], 'scripted')
        context = init_context(domain)
        probe = Probe(params, context=context)
        executor = EventsExecutor(context=context)  # as the nodes: it keeps up under load
        executor.add_node(probe)
        scenario = Scenario(probe, executor, lambda: world.poll() is None)
        try:
            scenario.run()
            if not probe.status:
                if world.poll() is not None:
                    pytest.exit(f'{name}: the implementation exited with status '
                                f'{world.poll()} before its first /world/status:\n'
                                f'{processes.log("world")[-3000:]}', returncode=1)
                scenario.graph = {'nodes': probe.get_node_names_and_namespaces()}
                return Run(name, chosen, params, probe, scenario, None,
                           processes.log('world'), None)
            deadline = time.monotonic() + EXIT_TIMEOUT
            while time.monotonic() < deadline and any(
                    process.poll() is None for process in (world, controllers, scripted)):
                spin_briefly(executor, 0.1)
            world_exit, controllers_exit = world.poll(), controllers.poll()
            if scripted.poll() != 0:
                scenario.log.append(f'the scripted robots (scripted.py) exited with '
                                    f'{scripted.poll()}: {processes.log("scripted")[-1500:]}')
        finally:
            executor.remove_node(probe)
            probe.destroy_node()
            executor.shutdown()
            rclpy.try_shutdown(context=context)
            processes.stop_all()  # the scripted robots too, whatever happened
        probe.take_record(record)
    return Run(name, chosen, params, probe, scenario, world_exit, processes.log('world'),
               controllers_exit)
