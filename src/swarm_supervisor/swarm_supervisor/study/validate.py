"""The whole design checked before any worker starts or a byte is written.

A study refuses (:class:`~swarm_supervisor.study.errors.StudyError`, exit status 2, one line
naming the key and the fix) what would otherwise fail in a worker halfway through, or quietly
run the same episode twice: a population of 0 robots, a level listed twice (two seeds of
the same value are one episode), a cell whose robots cannot be placed in its arena (the
engine's own placement, :func:`~swarm_supervisor.engine.episode.place_swarm`, is tried on
every episode: it costs milliseconds and is exactly the check an episode would fail), and a
cell whose files or metrics fail (:func:`~swarm_supervisor.engine.inputs.check_inputs` builds
the first state of each distinct cell once).
Empty lists and a factor's repeated levels are refused by the parameter schema already,
when the file is read.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

from mona_controller.schema import ParameterError
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import place_swarm
from swarm_supervisor.engine.inputs import check_inputs
from swarm_supervisor.study.errors import StudyError
from swarm_supervisor.study.specs import EpisodeSpec, design, episode_config
from swarm_world.placement import PlacementError


def _repeated(values: Iterable[Any]) -> list[Any]:
    """The values that occur more than once, in first-seen order."""
    seen: list[Any] = []
    twice: list[Any] = []
    for value in values:
        if value in seen and value not in twice:
            twice.append(value)
        seen.append(value)
    return twice


def check_design(config: SwarmConfig) -> list[EpisodeSpec]:
    """Check every cell of ``config.study`` and return its episodes (:func:`design`).

    Raises:
        StudyError: a population below 1, a level listed twice, two episodes with one folder
            name, or a cell whose population cannot be placed in its arena.
    """
    study = config.study
    empty = [n for n in study.populations if n < 1]
    if empty:
        raise StudyError(f'study.populations lists {empty[0]}: an episode needs at least one '
                         'robot (the mean pairwise distance and the ratio near the source are '
                         'undefined without robots); remove it from study.populations')
    lists: Sequence[tuple[str, Iterable[Any]]] = [
        ('study.populations', study.populations), ('study.speeds', study.speeds),
        ('study.seeds', study.seeds)]  # a factor's levels: the schema refuses repeats
    for key, values in lists:
        twice = _repeated(values)
        if twice:
            raise StudyError(f'{key} lists {twice[0]!r} more than once: each level is one '
                             f'cell (each seed one repetition), so the same episodes would '
                             f'run twice; remove the duplicate from {key}')
    specs = design(config)
    names = _repeated(spec.name for spec in specs)
    if names:
        raise StudyError(f'two episodes of the design share the folder name {names[0]} '
                         '(speeds that differ by less than 1e-6 cm/s?); make the levels of '
                         'study.speeds distinct')
    placed: set[tuple[Any, ...]] = set()
    built: set[str] = set()
    for spec in specs:
        episode = episode_config(config, spec)
        inputs = repr((episode.world, episode.mona, episode.controller, episode.metrics))
        if inputs not in built:  # the files and metrics of each distinct cell, once
            built.add(inputs)
            try:
                check_inputs(episode)
            except PlacementError:
                pass  # said below, with the fix for a study
            except ParameterError as error:
                raise StudyError(f'episode {spec.name}: {error}') from None
        # Placement depends on these only; one try per distinct combination and seed.
        placement = (spec.population, spec.seed, repr(episode.world), episode.mona.body_radius)
        if placement in placed:
            continue
        placed.add(placement)
        try:
            place_swarm(episode, spec.seed)
        except PlacementError as error:
            raise StudyError(f'study.populations: episode {spec.name}: {error}; remove '
                             f'{spec.population} from study.populations or enlarge '
                             'world.arena_side') from None
    return specs
