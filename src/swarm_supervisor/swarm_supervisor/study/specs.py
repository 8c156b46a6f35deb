"""The study's design: populations x speeds x extra factors x seeds, one episode each.

Any parameter of the schema can be an extra factor (``study.factors``, e.g.
``mona.ir_range: [0.02, 0.05]``), crossed with the others or, for a sensitivity design,
varied one at a time (``study.factor_design``). Each episode of the design is an
:class:`EpisodeSpec`, whose :attr:`~EpisodeSpec.name` is its folder
``DIR/episodes/N<pop>_v<cm/s>_s<seed>[_<key>=<level>...]/``. ``speed`` is in m/s, like every
speed in the parameter file.
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import Any

from swarm_supervisor.config import StudyParams, SwarmConfig


@dataclasses.dataclass(frozen=True)
class EpisodeSpec:
    """One cell of the design and one repetition in it."""

    population: int
    speed: float  #: m/s
    seed: int
    #: The extra factors' values in this episode, (dotted key, value) in declared order.
    levels: tuple[tuple[str, Any], ...] = ()
    #: The levels that name the episode: all of them in a crossed design, only the one that
    #: differs from the parameter file in a one-at-a-time design.
    named: tuple[tuple[str, Any], ...] = ()

    @property
    def name(self) -> str:
        """The episode's folder name, e.g. ``N30_v8_s1`` (speed in cm/s), followed by its
        named factor levels, e.g. ``N30_v8_s1_mona.ir_range=0.05``."""
        return f'N{self.population}_v{self.speed * 100:g}_s{self.seed}' + ''.join(
            f'_{key}={_level_text(value)}' for key, value in self.named)


#: A design cell: (its levels, the levels it names), each a tuple of (key, value).
Cell = tuple[tuple[tuple[str, Any], ...], tuple[tuple[str, Any], ...]]


def _level_text(value: Any) -> str:
    """A factor level in a folder name: the shortest exact text of a number."""
    return repr(value) if isinstance(value, float) else str(value)


def factor_cells(config: SwarmConfig) -> list[Cell]:
    """The combinations of extra factor levels: (levels, named levels) of each.

    Crossed: every combination. One-at-a-time: the parameter file's values, then each level
    of each factor that differs from them with the other factors at the file's values.
    """
    study = config.study
    if not study.factors:
        return [((), ())]
    base = tuple((key, parameter_value(config, key)) for key in study.factor_names)
    if study.factor_design == 'crossed':
        crossed = itertools.product(*([(key, v) for v in values] for key, values in study.factors))
        return [(cell, cell) for cell in map(tuple, crossed)]
    cells: list[Cell] = [(base, ())]
    for index, (key, values) in enumerate(study.factors):
        for value in values:
            if value != base[index][1]:
                cell = base[:index] + ((key, value),) + base[index + 1:]
                cells.append((cell, ((key, value),)))
    return cells


def parameter_value(config: SwarmConfig, key: str) -> Any:
    """The value of a dotted parameter key, e.g. ``mona.ir_range``."""
    return config.value(key)


def design(config: SwarmConfig) -> list[EpisodeSpec]:
    """Every episode of the study's design, in factor order: populations, speeds, the extra
    factors (:func:`factor_cells`), then seeds."""
    study = config.study
    return [EpisodeSpec(n, v, s, levels, named)
            for n, v, (levels, named), s in itertools.product(
                study.populations, study.speeds, factor_cells(config), study.seeds)]


def quick_study(study: StudyParams) -> StudyParams:
    """A reduced design for a smoke test: N = 5 and 10, the same speeds and extra factors,
    two seeds, 60 s.

    The snapshot times are scaled from the full duration to the short one, so fig. 3 still
    shows the start, an intermediate and the end of the episode.
    """
    duration = 60.0
    scale = duration / study.duration
    return dataclasses.replace(
        study, populations=(5, 10), seeds=study.seeds[:2], duration=duration,
        snapshot_times=tuple(sorted({round(t * scale, 3) for t in study.snapshot_times})))


def episode_config(config: SwarmConfig, spec: EpisodeSpec) -> SwarmConfig:
    """The full configuration of one episode of ``config.study``."""
    return config.with_values({
        'episode.population': spec.population, 'episode.seed': spec.seed,
        'episode.duration': config.study.duration, 'controller.speed': spec.speed,
        **dict(spec.levels)})


def snapshot_times(study: StudyParams) -> tuple[float, ...]:
    """When each episode keeps a cue map: the study's times within the episode, and its end."""
    return tuple(sorted({t for t in study.snapshot_times if t <= study.duration}
                        | {study.duration}))

