"""The held-out comparison of controllers (``mona-swarm heldout``): every controller on the
same held-out seeds of every scenario, paired.

A plan is a YAML file with one mapping, ``heldout``::

    heldout:
      seeds: held_out_seeds.yaml     # a YAML file with a list 'seeds' (relative to this
                                     # file), fixed before anything ran on them
      robots: 30                     # N
      duration: 1000.0               # s per episode
      batch: 32                      # at most this many episodes stepped together
      behaviour_seeds: 10            # the behaviour table over the first so many seeds
      scenarios:                     # name -> the parameter file an episode starts from,
        paper: {config: ../mona_swarm.yaml}            # and changes to its world section
        pairs: {config: moving_leaks.yaml, world: {cleaning_quorum: 2}}
      controllers:                   # name -> the parameter file whose controller section
        beeclust: {}                 # runs ('' or none: the scenario's own), and changes
        mine: {config: ../controllers/mine.yaml, controller: {...}}    # to it
      pairs: [[mine, beeclust]]      # the paired tests: [a, b] tests a against b
      figure: [leaks, pairs]         # the scenarios of the figure of cue left against k

An episode is the scenario's parameters with the controller's section (its file's, then the
plan's changes, merged key by key) at ``robots``, ``duration`` and the seed. Each
(scenario, controller) runs as one chunk of batches and is written to
``scores/<scenario>.<controller>.csv`` (seed, fitness: the mean cue fraction over the
episode, final: the cue fraction at its end) once complete, so an interrupted comparison
resumes where it stopped; the statistics (:mod:`.heldout_stats`) read the chunks.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import os
from pathlib import Path
from typing import Any

import yaml

from mona_controller.mappings import from_mapping
from mona_controller.schema import ParameterError
from swarm_supervisor.config import SwarmConfig, load_config
from swarm_supervisor.engine.runner import run_batch
from swarm_supervisor.evolution.fitness import episode_fitness, run_scores
from swarm_supervisor.study.interrupt import raise_if_stopped

#: The plan's keys: (type, default); None = required.
KEYS: dict[str, tuple[type, Any]] = {
    'seeds': (str, None), 'robots': (int, 30), 'duration': (float, 1000.0),
    'batch': (int, 32), 'behaviour_seeds': (int, 10), 'scenarios': (dict, None),
    'controllers': (dict, None), 'pairs': (list, []), 'figure': (list, []),
}


class PlanError(ParameterError):
    """A comparison plan is malformed (exit status 2, the message names the key)."""


@dataclasses.dataclass(frozen=True)
class Plan:
    """A loaded, checked plan: each scenario's and controller's base parameters resolved."""

    path: str
    seeds: tuple[int, ...]
    robots: int
    duration: float
    batch: int
    behaviour_seeds: int
    scenarios: dict[str, tuple[SwarmConfig, dict[str, Any]]]
    controllers: dict[str, tuple[SwarmConfig | None, dict[str, Any]]]
    pairs: tuple[tuple[str, str], ...]
    figure: tuple[str, ...]


def merged(base: dict[str, Any], changes: dict[str, Any]) -> dict[str, Any]:
    """``base`` with ``changes`` merged in, key by key at every level (a copy)."""
    out = dict(base)
    for key, value in changes.items():
        out[key] = merged(out[key], value) if isinstance(value, dict) and isinstance(
            out.get(key), dict) else value
    return out


def episode_config(plan: Plan, scenario: str, controller: str, seed: int) -> SwarmConfig:
    """One episode: the scenario with the controller's section, N, duration and ``seed``."""
    base, world = plan.scenarios[scenario]
    own, changes = plan.controllers[controller]
    mapping = base.to_dict()
    mapping['world'] = merged(mapping['world'], world)
    section = (own or base).to_dict()['controller']
    mapping['controller'] = merged(section, changes)
    mapping['episode'] = {**mapping['episode'], 'population': plan.robots,
                          'duration': plan.duration, 'seed': seed}
    return from_mapping(SwarmConfig, mapping)


def _checked(path: Path, section: dict[str, Any]) -> dict[str, Any]:
    unknown = sorted(set(section) - set(KEYS))
    if unknown:
        raise PlanError(f'{path}: unknown key heldout.{unknown[0]}; known: ' + ', '.join(KEYS))
    values = {}
    for key, (kind, default) in KEYS.items():
        value: Any = section.get(key, default)
        if value is None:
            raise PlanError(f'{path}: heldout.{key} is missing')
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, kind) or isinstance(value, bool):
            raise PlanError(f'{path}: heldout.{key} = {value!r}: expected a {kind.__name__}')
        if isinstance(value, (int, float)) and value <= 0:
            raise PlanError(f'{path}: heldout.{key} = {value!r} must be > 0')
        values[key] = value
    return values


def _entry(path: Path, where: str, value: Any, section: str) -> tuple[SwarmConfig | None,
                                                                        dict[str, Any]]:
    """A scenario's or controller's (parameters of its file or None, changes)."""
    if not isinstance(value, dict) or set(value) - {'config', section}:
        raise PlanError(f'{path}: {where} = {value!r}: expected a mapping of config and '
                        f'{section}')
    changes = value.get(section, {})
    if not isinstance(changes, dict):
        raise PlanError(f'{path}: {where}.{section} must be a mapping')
    if not value.get('config'):
        return None, changes
    try:
        return load_config(path.parent / value['config']), changes
    except ParameterError as error:
        raise PlanError(f'{path}: {where}.config: {error}') from None


def load_plan(path: str | Path) -> Plan:
    """Load and check a plan: keys, seeds, parameter files, pairs, and one episode of every
    scenario with every controller built (so a bad change fails before anything runs).

    Raises:
        PlanError: naming the key or entry at fault.
    """
    path = Path(path)
    try:
        document = yaml.safe_load(path.read_text())
        seeds_file = path.parent / str((document or {}).get('heldout', {}).get('seeds', ''))
        seeds = yaml.safe_load(seeds_file.read_text())['seeds'] if seeds_file.is_file() \
            else None
    except (OSError, yaml.YAMLError, TypeError, KeyError, AttributeError) as error:
        raise PlanError(f'cannot read the plan {path} or its seeds: {error}') from None
    if not isinstance(document, dict) or set(document) != {'heldout'}:
        raise PlanError(f"{path}: expected one mapping, 'heldout'")
    values = _checked(path, document['heldout'] or {})
    if not (isinstance(seeds, list) and seeds and all(
            isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds)
            and len(set(seeds)) == len(seeds)):
        raise PlanError(f'{path}: heldout.seeds = {values["seeds"]!r}: expected a file with '
                        "a list 'seeds' of distinct whole numbers >= 0")
    scenarios = {}
    for name, value in values['scenarios'].items():
        base, world = _entry(path, f'heldout.scenarios.{name}', value, 'world')
        if base is None:
            raise PlanError(f'{path}: heldout.scenarios.{name}.config is missing')
        scenarios[str(name)] = (base, world)
    controllers = {str(name): _entry(path, f'heldout.controllers.{name}', value, 'controller')
                   for name, value in values['controllers'].items()}
    pairs = []
    for pair in values['pairs']:
        if not (isinstance(pair, list) and len(pair) == 2 and set(pair) <= set(controllers)):
            raise PlanError(f'{path}: heldout.pairs: {pair!r} is not two of the controllers '
                            f'({", ".join(controllers)})')
        pairs.append((pair[0], pair[1]))
    if not set(values['figure']) <= set(scenarios):
        raise PlanError(f'{path}: heldout.figure names a scenario not in heldout.scenarios')
    plan = Plan(str(path), tuple(seeds), values['robots'], values['duration'],
                values['batch'], values['behaviour_seeds'], scenarios, controllers,
                tuple(pairs), tuple(values['figure']))
    for scenario in scenarios:
        for controller in controllers:
            try:
                episode_config(plan, scenario, controller, seeds[0])
            except ParameterError as error:
                raise PlanError(f'{path}: scenario {scenario} with controller {controller}: '
                                f'{error}') from None
    return plan


def episode_scores(configs: list[SwarmConfig]) -> list[tuple[float, float]]:
    """Each episode's (fitness, final cue fraction), the episodes stepped together."""
    return [(episode_fitness(result.metrics), result.metrics[-1]['mean_cue_fraction'])
            for result in run_batch(configs)]


def chunk_path(out: Path, scenario: str, controller: str) -> Path:
    """Where one (scenario, controller)'s scores are written."""
    return out / 'scores' / f'{scenario}.{controller}.csv'


def run_chunks(plan: Plan, out: Path, pool: Any | None, jobs: int,
               only: set[str] | None = None) -> None:
    """Score every (scenario, controller) not yet written (with ``only``, just those
    controllers), each written whole once done."""
    (out / 'scores').mkdir(parents=True, exist_ok=True)
    for scenario in plan.scenarios:
        for controller in plan.controllers:
            path = chunk_path(out, scenario, controller)
            if path.exists() or (only is not None and controller not in only):
                continue
            raise_if_stopped()  # a signal whose exception was swallowed (docs/study.md)
            configs = [episode_config(plan, scenario, controller, seed) for seed in plan.seeds]
            scores = run_scores(configs, plan.batch, pool, jobs, episode_scores)
            text = io.StringIO()
            writer = csv.writer(text, lineterminator='\n')
            writer.writerow(('seed', 'fitness', 'final'))
            writer.writerows((seed, repr(fit), repr(end))
                             for seed, (fit, end) in zip(plan.seeds, scores))
            tmp = path.with_name(path.name + '.tmp')
            tmp.write_text(text.getvalue())
            os.replace(tmp, path)


def read_chunk(out: Path, scenario: str, controller: str) -> dict[str, list[float]] | None:
    """A chunk's columns (seed, fitness, final), None if it has not run."""
    path = chunk_path(out, scenario, controller)
    if not path.exists():
        return None
    with path.open() as handle:
        rows = list(csv.DictReader(handle))
    return {key: [float(row[key]) for row in rows] for key in ('seed', 'fitness', 'final')}
