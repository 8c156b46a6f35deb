"""The ``mona-swarm`` command: run an episode, run the study, replay and analyse bags, videos,
and the ROS node system (``launch``, what scripts/swarm.sh runs).

Each subcommand lives in its own module exposing ``register(subparsers)``, which adds its
parser and sets ``handler``; a handler returns the exit status
(:mod:`swarm_supervisor.exits`). Bad arguments and bad parameters exit with status 2 and a
one-line message naming the problem.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings

from mona_controller.schema import DeprecatedKeyWarning, ParameterError
from swarm_supervisor import __version__, exits
from swarm_supervisor.outputs.guard import RecordExists
from swarm_world.placement import PlacementError

#: Modules that contribute subcommands, in the order ``--help`` lists them, with the
#: subcommands each adds (so a command imports only its own module's libraries).
COMMAND_MODULES = {
    'swarm_supervisor.cli.run': ('run',),
    'swarm_supervisor.cli.study': ('study',),
    'swarm_supervisor.cli.bags': ('analyze', 'replay', 'recover'),
    'swarm_supervisor.cli.animate': ('animate',),
    'swarm_supervisor.cli.calibrate': ('calibrate',),
    'swarm_supervisor.cli.evolve': ('evolve',),
    'swarm_supervisor.cli.heldout': ('heldout',),
    'swarm_supervisor.cli.launch': ('launch',),
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser: with ``command``, only the module that provides it is loaded."""
    parser = argparse.ArgumentParser(
        prog='mona-swarm', epilog=exits.HELP + '.',
        description='Mona swarm pollution-source localisation and cleanup (BEECLUST).')
    parser.add_argument('--version', action='version', version=f'%(prog)s {__version__}')
    subparsers = parser.add_subparsers(dest='command', required=True, metavar='COMMAND')
    modules = [name for name, commands in COMMAND_MODULES.items() if command in commands]
    for name in modules or COMMAND_MODULES:
        importlib.import_module(name).register(subparsers)
    return parser


_SHOW = warnings.showwarning


def _show(message, category, filename, lineno, file=None, line=None) -> None:
    """A renamed parameter key still in use as one line; any other warning as Python shows
    it."""
    if issubclass(category, DeprecatedKeyWarning):
        print(f'mona-swarm: warning: {message}', file=sys.stderr)
    else:
        _SHOW(message, category, filename, lineno, file, line)


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the process exit status."""
    argv = sys.argv[1:] if argv is None else argv
    # A renamed key is worth a line to the user (Python hides a DeprecationWarning from the
    # user of a command by default): once per key.
    warnings.simplefilter('default', DeprecatedKeyWarning)
    warnings.showwarning = _show
    command = argv[0] if argv else None
    try:
        # Building the parser imports the command's modules, and with them the plug-ins
        # they load: one that does not import is a bad input like any other.
        args = build_parser(command).parse_args(argv)
        command = args.command
        return int(args.handler(args) or exits.OK)
    except (ParameterError, PlacementError, RecordExists) as error:
        print(f'mona-swarm{f" {command}" if command else ""}: error: {error}', file=sys.stderr)
        return exits.USAGE
    except KeyboardInterrupt:
        print(f'mona-swarm{f" {command}" if command else ""}: interrupted', file=sys.stderr)
        return exits.INTERRUPTED
