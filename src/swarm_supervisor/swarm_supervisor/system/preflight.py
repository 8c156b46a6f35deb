"""What the launcher checks before it starts a process or writes a byte: the options against
each other, the parameters as the nodes will read them, the domain asked for. Pure: each check
returns what it found or raises :class:`UsageError` / ``ParameterError`` naming the option and
the fix (exit status 2)."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import yaml

from mona_controller.schema import ParameterError
from swarm_supervisor.config import SwarmConfig, load_config


class UsageError(Exception):
    """A bad option, or something missing to start: exit status 2, nothing started."""


def check_roles(options: argparse.Namespace, population: int) -> None:
    """The role options fit together and the population.

    Raises:
        UsageError: naming the option.
    """
    if options.role == 'controllers':
        if options.robots is None:
            raise UsageError('--role controllers needs --robots IDS (e.g. 0-24)')
        beyond = [robot for robot in options.robots if robot >= population]
        if beyond:
            raise UsageError(f'--robots: robot {beyond[0]} is beyond the population of '
                             f'{population} (ids 0..{population - 1})')
    elif options.robots is not None:
        raise UsageError('--robots goes with --role controllers')


def run_overrides(options: argparse.Namespace) -> list[str]:
    """The ``NAME:=VALUE`` overrides every node gets: the options' parameters, then ``-p``."""
    overrides = []
    if options.population is not None:
        overrides.append(f'episode.population:={options.population}')
    if options.duration is not None:
        overrides.append(f'episode.duration:={options.duration!r}')
    if options.seed is not None:
        overrides.append(f'episode.seed:={options.seed}')
    if options.speed is not None:
        overrides.append(f'controller.speed:={options.speed / 100!r}')
    return overrides + options.params


def check_parameters(config_path: Path, overrides: list[str]) -> SwarmConfig:
    """The run's parameters: the file with the overrides of model parameters (``section.key``)
    applied and validated like the nodes do. Node options (``lockstep_deadline``) pass as is.

    Raises:
        ParameterError: naming the bad parameter.
    """
    config = load_config(config_path)
    known = config.to_dict()
    sections: dict[str, dict] = {}
    for text in overrides:
        name, _, value = text.partition(':=')
        section, _, key = name.partition('.')
        if key and section in known:
            try:
                sections.setdefault(section, {})[key] = yaml.safe_load(value)
            except yaml.YAMLError:
                raise ParameterError(f'{name} = {value!r} is not a YAML value') from None
    config = config.replace(**sections)
    if config.episode.population < 1:
        raise ParameterError('episode.population = 0: a ros run needs a robot')
    return config


def forced_domain() -> int | None:
    """The domain id of ``SWARM_DOMAIN_ID``, if set (the caller's choice: no lock, no check)."""
    text = os.environ.get('SWARM_DOMAIN_ID', '')
    if not text:
        return None
    if not (text.isdigit() and int(text) <= 232):
        raise UsageError(f"SWARM_DOMAIN_ID '{text}': expected 0..232")
    return int(text)
