"""The command line of each node of a launch, in start order (:func:`node_commands`)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from swarm_supervisor.system.preflight import config_file, run_overrides
from swarm_supervisor.system.records import LIVE_RECORDER

#: What each ``--role`` starts: the whole system on one host, or the part for one host
#: ('supervision': the core without the world, for a driver of real Monas that replaces it).
ROLES = {'all': ('world', 'metrics', 'controller', 'supervisor'),
         'core': ('world', 'metrics', 'supervisor'),
         'supervision': ('metrics', 'supervisor'),
         'controllers': ('controller',)}


def controller_groups(population: int, per_process: int,
                      robots: list[int] | None = None) -> list[str]:
    """The ``--robots`` of each controller process: '0', '1', ... or '0-9', '10-19', ...,
    for every robot of the population or only ``robots`` (in the given order)."""
    ids = list(range(population)) if robots is None else list(robots)
    groups = []
    for start in range(0, len(ids), per_process):
        chunk = ids[start:start + per_process]
        if chunk == list(range(chunk[0], chunk[-1] + 1)):
            groups.append(str(chunk[0]) if len(chunk) == 1 else f'{chunk[0]}-{chunk[-1]}')
        else:
            groups.append(','.join(map(str, chunk)))
    return groups


def node_commands(options: argparse.Namespace, population: int, out: Path,
                  executables: dict[str, str]) -> dict[str, list[str]]:
    """Node name -> command line, in start order: world, metrics, controllers, the live node,
    supervisor; only the nodes of ``options.role`` (when given)."""
    ros_args = ['--ros-args', '--params-file', str(config_file(options))]
    for override in run_overrides(options):
        ros_args += ['-p', override]
    # Starting many Python processes takes a while on a small machine: scale the patience.
    start_timeout = options.start_timeout or max(60, 3 * population)
    commands = {
        'world': [executables['world'], *ros_args, '-p', f'mode:={options.mode}',
                  '-p', f'output_dir:={out}', '-p', f'start_timeout:={start_timeout}.0',
                  '-p', 'recorders:=metrics'],
        'metrics': [executables['metrics'], *ros_args, '-p', f'output_dir:={out}']}
    for robots in controller_groups(population, options.per_process,
                                    getattr(options, 'robots', None)):
        commands[f'controller_{robots}'] = [executables['controller'], '--robots', robots,
                                            *ros_args]
    if getattr(options, 'live', False):  # before the supervisor: it sees the whole episode
        linger = getattr(options, 'linger', None)
        commands['live'] = [sys.executable, '-m', 'swarm_supervisor.system.ros.live_node',
                            '--ros-args', '-p', f'port:={options.live_port}',
                            '-p', f'linger:={-1.0 if linger is None else float(linger)}']
    # The live node reports like a recorder: an episode ends once it holds the final state.
    recorders = f'metrics,{LIVE_RECORDER}' if 'live' in commands else 'metrics'
    commands['supervisor'] = [executables['supervisor'], *ros_args,
                              '-p', f'episodes:={options.episodes}', '-p', f'output_dir:={out}',
                              '-p', f'recorders:={recorders}']
    kinds = ROLES[getattr(options, 'role', 'all')] + ('live',)
    return {name: command for name, command in commands.items()
            if name.partition('_')[0] in kinds}
