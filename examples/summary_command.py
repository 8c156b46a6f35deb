"""A ``mona-swarm`` subcommand of your own: ``mona-swarm summary DIR`` prints one line per
episode folder under DIR (population, speed, seed, the cue left at the end).

To add it to the command, list its module in ``COMMAND_MODULES`` of
``swarm_supervisor/cli/command.py`` (``'examples.summary_command': ('summary',)``, or move
the file into ``swarm_supervisor/cli/``); docs/extending.md, "A CLI subcommand".
"""

from __future__ import annotations

import argparse
from pathlib import Path

from swarm_supervisor import exits, outputs, study


def register(subparsers) -> None:
    """Add the ``summary`` subcommand (the contract of every subcommand module)."""
    parser = subparsers.add_parser('summary', help='one line per episode of a folder',
                                   description='Print N, speed, seed and the cue left at the '
                                               'end of every episode folder under DIR.',
                                   epilog=exits.HELP + '.')
    parser.add_argument('folder', type=Path, metavar='DIR')
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """The handler: returns the exit status. A StudyError (a ParameterError) is reported by
    ``mona-swarm`` itself as one line with status 2."""
    folders = study.find_episodes([args.folder])
    if not folders:
        raise study.StudyError(f'{args.folder} holds no episode folder')
    for folder in folders:
        key = study.episode_key(folder)
        left = outputs.read_metrics_csv(folder / outputs.METRICS_FILE)['mean_cue_fraction'][-1]
        print(f'{folder.name}: N = {key["population"]}, {key["speed"] * 100:g} cm/s, seed '
              f'{key["seed"]}: {left:.1%} of the cue left')
    return exits.OK
