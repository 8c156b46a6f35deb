"""What the launcher checks before it starts a process or writes a byte: the options against
each other, the parameters as the nodes will read them, the domain asked for. Pure: each check
returns what it found or raises :class:`UsageError` / ``ParameterError`` naming the option and
the fix (exit status 2)."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

import yaml

from mona_controller.schema import ParameterError
from swarm_supervisor.config import SwarmConfig, file_relative_overrides, load_config
from swarm_supervisor.engine.episode import place_swarm
from swarm_world.placement import MAX_COVERAGE, PlacementError


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
    """The ``NAME:=VALUE`` overrides every node gets: the parameter file's relative file
    paths resolved against it (:func:`~swarm_supervisor.config.file_relative_overrides`),
    the options' parameters, then ``-p``."""
    overrides = file_relative_overrides(options.config)
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
    values = {}
    for text in overrides:
        name, _, value = text.partition(':=')
        section, _, key = name.partition('.')
        if key and section in known:
            try:
                values[name] = yaml.safe_load(value)
            except yaml.YAMLError:
                raise ParameterError(f'{name} = {value!r} is not a YAML value') from None
    config = config.with_values(values)
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


#: DDS participants one host's domain holds: the shipped profile probes participant ids
#: 0..119 (all a domain's port block has room for), so a 121st is never discovered.
PARTICIPANTS = 120


def domain_capacity(domain: int | None) -> int:
    """The participants one host can have in ``domain``: :data:`PARTICIPANTS`, fewer near the
    top of the id range, where participant p's unicast ports (7400 + 250 domain + 10 + 2 p,
    and + 1) would pass 65535 (domain 232: 63)."""
    if domain is None:
        return PARTICIPANTS
    return max(0, min(PARTICIPANTS, (65535 - (7400 + 250 * domain + 11)) // 2 + 1))


#: Episodes whose placement :func:`check_fit` tries (600 robots take about 40 ms each); a
#: later seed that cannot be placed fails the supervisor, naming it.
FIT_EPISODES = 50


def check_fit(config: SwarmConfig, episodes: int, option: str = '--population') -> None:
    """Every episode's robots can be placed: the placement the supervisor node will do (the
    embedded runner's, :func:`~swarm_supervisor.engine.episode.place_swarm`) for the seed of
    each episode (``episode.seed + k``), the first :data:`FIT_EPISODES` of them.

    Raises:
        UsageError: naming the population, the arena and the largest one that could fit.
    """
    population = config.episode.population
    for k in range(min(episodes, FIT_EPISODES)):
        seed = config.episode.seed + k
        try:
            place_swarm(config, seed)
        except PlacementError as error:
            floor = config.world.arena_side ** 2 - sum(
                obstacle.area for obstacle in config.world.arena().obstacles)
            most = max(0, int(MAX_COVERAGE * floor / (math.pi * config.mona.body_radius ** 2)))
            reason = str(error).split(': ', 1)[-1]
            raise UsageError(
                f'{option} {population} does not fit a {config.world.arena_side} m arena '
                f'(episode {k}, seed {seed}: {reason}); give a smaller {option} (at most '
                f'~{most})') from None


def hosted_robots(options: argparse.Namespace, population: int) -> int:
    """The robots whose controllers run on this host (by ``--role`` and ``--robots``)."""
    if options.role == 'controllers' and options.robots is not None:
        return len(options.robots)
    return population if options.role in ('all', 'controllers') else 0


def participants(options: argparse.Namespace, population: int, per_process: int = 0) -> int:
    """The DDS participants the run has on this host: one per controller process (of
    ``per_process`` robots, default ``--controllers-per-process``), one per node of the core
    its role runs (world, metrics, supervisor) and the live node."""
    core = {'all': 3, 'core': 3, 'supervision': 2, 'controllers': 0}[options.role]
    live = 1 if getattr(options, 'live', False) else 0
    robots = hosted_robots(options, population)
    return math.ceil(robots / (per_process or options.per_process)) + core + live


def check_participants(options: argparse.Namespace, population: int,
                       domain: int | None = None) -> None:
    """This host's participants fit one domain (:func:`domain_capacity`: 120, fewer for the
    last ids).

    Raises:
        UsageError: naming the count and the smallest ``--controllers-per-process`` that fits.
    """
    limit = domain_capacity(domain)
    count = participants(options, population)
    if count <= limit:
        return
    robots = hosted_robots(options, population)
    fits = [k for k in range(options.per_process + 1, robots + 1)
            if participants(options, population, k) <= limit]
    hint = f'give --controllers-per-process {fits[0]}' if fits else 'run fewer nodes here'
    where = f'domain {domain}' if limit < PARTICIPANTS else 'one domain'
    raise UsageError(
        f'{robots} robots at {options.per_process} per process are {count} DDS participants on '
        f'this host (about {limit} fit {where}): {hint}')


def node_run_in(folder: Path) -> Path | None:
    """A file that shows ``folder`` holds (part of) an earlier node-system run, or None: its
    ``run.json`` or ``processes.tsv``, or a bag's ``metadata.yaml`` or ``.mcap`` under
    ``episode_<k>/bag*`` (also of a run stopped before the supervisor wrote run.json)."""
    folder = Path(folder)
    if not folder.is_dir():
        return None
    for name in ('run.json', 'processes.tsv'):
        if (folder / name).is_file():
            return folder / name
    for bag in sorted(folder.glob('episode_*/bag*')):
        found = sorted(bag.glob('metadata.yaml')) + sorted(bag.glob('*.mcap'))
        if found:
            return found[0]
    return None
