"""The ``mona-swarm`` command: one parser, one subcommand module each, named exit codes."""

from swarm_supervisor.cli.command import main

__all__ = ['main']
