"""Placement, episodes, the embedded runner, the study and the mona-swarm command."""

__version__ = '0.1.0'
