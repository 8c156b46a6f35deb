"""``mona-swarm launch``: the node system as real processes (what ``scripts/swarm.sh`` runs).

    mona-swarm launch --population 10 --episodes 2 --out results/ros

One world, one metrics node, the controllers (K robots per process) and the supervisor, each in
its own process group in a private ROS domain (:mod:`swarm_supervisor.system.launcher`).
Across machines, each host runs a part: ``--role core`` (world, metrics, supervisor) on one,
``--role controllers --robots 0-24`` on others, all with the same ``--domain`` and a
``--peers`` list of the hosts' addresses. docs/running.md has the details.
"""

from __future__ import annotations

import argparse
import ipaddress
from pathlib import Path

from swarm_supervisor import exits
from swarm_supervisor.cli.arguments import bounded, speed_cm_s_unbounded
from swarm_supervisor.system.launcher import ROLES, launch

DESCRIPTION = ('Run the node system (world, supervisor, metrics and the controllers) as real '
               'processes; wait for the supervisor, then stop everything.')
EPILOG = ('Environment: SWARM_DOMAIN_ID forces the ROS domain id; SWARM_FASTDDS_PROFILE names '
          'another Fast DDS profile. ' + exits.HELP + '.')


def register(subparsers) -> None:
    """Add the ``launch`` subcommand."""
    parser = subparsers.add_parser('launch', help='run the ROS node system (scripts/swarm.sh)',
                                   description=DESCRIPTION, epilog=EPILOG, allow_abbrev=False)
    add_options(parser)
    parser.set_defaults(handler=launch)


def build_parser() -> argparse.ArgumentParser:
    """The launcher's options as a parser of their own (prog ``mona-swarm launch``)."""
    parser = argparse.ArgumentParser(prog='mona-swarm launch', description=DESCRIPTION,
                                     epilog=EPILOG, allow_abbrev=False)
    add_options(parser)
    return parser


def _file(text: str) -> Path:
    path = Path(text)
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"'{text}': no such file")
    return path.resolve()


def _override(text: str) -> str:
    name, sep, _ = text.partition(':=')
    if not (name and sep):
        raise argparse.ArgumentTypeError(f"'{text}': expected NAME:=VALUE")
    return text


def parse_robots(spec: str) -> list[int]:
    """Robot ids from ``'3'``, ``'0-24'`` or ``'0,2,5-7'`` (the controller node's syntax)."""
    ids: list[int] = []
    for part in spec.split(','):
        first, _, last = part.strip().partition('-')
        if not first.isdigit() or (last and not last.isdigit()) or int(last or first) < int(first):
            raise argparse.ArgumentTypeError(f"'{spec}': expected ids like 3, 0-24 or 0,2,5-7")
        ids.extend(range(int(first), int(last or first) + 1))
    if len(set(ids)) != len(ids):
        raise argparse.ArgumentTypeError(f"'{spec}': a robot id is repeated")
    return ids


def _peers(text: str) -> list[str]:
    peers = [part.strip() for part in text.split(',') if part.strip()]
    for peer in peers:
        try:
            ipaddress.IPv4Address(peer)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{peer}': expected an IPv4 address") from None
    if not peers:
        raise argparse.ArgumentTypeError('expected IP,IP,...')
    return peers


def add_options(parser: argparse.ArgumentParser) -> None:
    """The launcher's options (``mona-swarm launch``, ``scripts/swarm.sh``)."""
    add = parser.add_argument
    add('--population', type=bounded(int, 0), metavar='N',
        help="robots (default: the config's episode.population)")
    add('--speed', type=speed_cm_s_unbounded, metavar='CM_PER_S',
        help='robot speed in cm/s (sets controller.speed = CM_PER_S / 100 m/s); below 0.5 '
             'is refused as m/s')
    add('--episodes', type=bounded(int, 1), default=1, metavar='E',
        help='episodes to run one after the other (default 1)')
    add('--duration', type=bounded(float, 0.0, unit='s'), metavar='SECONDS',
        help='simulated seconds per episode (default: episode.duration)')
    add('--seed', type=bounded(int, 0), metavar='S',
        help='seed of the first episode (default: episode.seed)')
    add('--out', type=Path, metavar='DIR',
        help='output folder (default results/swarm-<date>-<time>)')
    add('--overwrite', action='store_true',
        help='--out may hold an earlier run (or another record): delete it whole first '
             '(default: refuse, exit 2)')
    add('--mode', choices=('lockstep', 'realtime'), default='lockstep',
        help='stepping (default lockstep)')
    add('--config', type=_file, metavar='YAML',
        help='parameter file (default: the shipped mona_swarm.yaml, ros_ws/config/ in the '
             'source tree)')
    add('--controllers-per-process', dest='per_process', type=bounded(int, 1), default=1,
        metavar='K', help='robots per controller process, one node each (default 1)')
    add('--timeout', type=bounded(int, 0, unit='s'), default=0, metavar='SECONDS',
        help='wall-clock limit for the whole run, 0 = none (default 0)')
    add('--start-timeout', type=bounded(int, 1, unit='s'), metavar='SECONDS',
        help='how long the world waits for every controller and the metrics node to be ready '
             'for an episode (default max(60, 3 N) s)')
    add('-p', dest='params', type=_override, action='append', default=[],
        metavar='NAME:=VALUE', help='extra ROS parameter override for every node (repeatable)')
    add('--role', choices=tuple(ROLES), default='all',
        help='what this host runs: all (default), core (world, metrics, supervisor), '
             'supervision (metrics, supervisor: a real-robot driver replaces the world) or '
             'controllers (those of --robots); a split run needs --domain on every host')
    add('--robots', type=parse_robots, metavar='IDS',
        help='with --role controllers: the robots whose controllers run here, e.g. 0-24')
    add('--peers', type=_peers, metavar='IP,IP',
        help="every host's address (this one's too): discover by unicast over the LAN "
             'instead of loopback (writes <out>/fastdds_peers.xml)')
    add('--live', action='store_true',
        help='also serve the run to Foxglove (the live node, '
             'swarm_supervisor.system.ros.live_node)')
    add('--live-port', type=bounded(int, 0, 65535), default=8765, metavar='PORT',
        help='--live: its WebSocket port on localhost (default 8765)')
    add('--linger', type=bounded(float, 0.0, 1e6), metavar='SECONDS',
        help='--live: after the run, keep serving its final state for SECONDS (default: '
             'until Ctrl-C, which then exits 0: the outputs are complete; 0: stop with the '
             'run)')
    add('--domain', type=bounded(int, 0, 232), metavar='ID',
        help='ROS domain id, the same on every host of a split run (default: a free one, '
             'or SWARM_DOMAIN_ID)')
