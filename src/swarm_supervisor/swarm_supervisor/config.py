"""The whole parameter set of a run, loaded from the one YAML both runners read.

The file is a ROS 2 parameter file whose ``/**`` wildcard section holds every parameter, so
``--ros-args --params-file`` hands the same values to each node::

    /**:
      ros__parameters:
        episode: {population: 30, duration: 4000.0, seed: 1}
        world: {arena_side: 2.85, ...}
"""

from __future__ import annotations

import dataclasses
import os
import sys
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from mona_controller.controllers.params import ControllerParams
from mona_controller.keys import leaf, renamed_keys
from mona_controller.mona import MonaParams
from mona_controller.schema import (
    DeprecatedKeyWarning,
    ParameterError,
    from_mapping,
    merged,
    param,
    to_mapping,
    unflatten,
    validate,
)
from swarm_metrics.metrics import MetricsParams
from swarm_world.params import WorldParams
from swarm_world.timing import steps_for

#: The parameter file shipped with the project.
#: The shipped parameter file in the source tree (ros_ws/config/mona_swarm.yaml).
DEFAULT_CONFIG = Path(__file__).resolve().parents[3] / 'ros_ws' / 'config' / 'mona_swarm.yaml'
#: Where an installed swarm_supervisor keeps its copy, below an install prefix.
INSTALLED_CONFIG = Path('share') / 'swarm_supervisor' / 'config' / 'mona_swarm.yaml'


def default_config_path() -> Path:
    """The default parameter file: the source tree's, else the installed package's (below this
    Python's prefix, or a colcon workspace on AMENT_PREFIX_PATH).

    Raises:
        ParameterError: none is there (silently falling back to built-in defaults would run
            other parameters than the file a user edits).
    """
    prefixes = [Path(sys.prefix), *(Path(p) for p in
                                     os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)
                                     if p)]
    candidates = [DEFAULT_CONFIG, *(prefix / INSTALLED_CONFIG for prefix in prefixes)]
    for candidate in candidates:
        if candidate.is_file():
            return candidate
    raise ParameterError('the default parameter file mona_swarm.yaml is missing (looked in '
                         + ', '.join(str(c) for c in candidates) + '); reinstall the '
                         'packages or pass a parameter file (--config)')


@dataclasses.dataclass(frozen=True)
class EpisodeParams:
    """One episode: how many robots, for how long, from which seed."""

    population: int = param(30, unit='robots', low=0, high=100_000,
                            doc='number of Monas (N)')
    duration: float = param(4000.0, unit='s', low=0.001, high=1e7,
                            doc='simulated length of the episode')
    seed: int = param(1, low=0, high=2**63 - 1,
                      doc='episode seed: placement and every controller derive from it')

    def __post_init__(self) -> None:
        validate(self, 'episode.')


#: How the extra factors of a study combine (see :class:`StudyParams`).
FACTOR_DESIGNS = ('crossed', 'one-at-a-time')
#: Parameters the design sets itself, so they cannot be extra factors.
DESIGN_KEYS = {'episode.population': 'study.populations', 'controller.speed': 'study.speeds',
               'episode.seed': 'study.seeds', 'episode.duration': 'study.duration'}


@dataclasses.dataclass(frozen=True)
class StudyParams:
    """The factorial design of the study (the paper's section on experiments; docs/study.md):
    populations x speeds x seeds, crossed with any extra factors: other parameters, each with a
    list of levels."""

    populations: tuple[int, ...] = param((10, 20, 30, 40, 50), unit='robots', low=0,
                                         high=100_000, doc='population factor N')
    speeds: tuple[float, ...] = param((0.04, 0.08), unit='m/s', low=0.0, high=1.0,
                                      doc='speed factor v_r')
    seeds: tuple[int, ...] = param((1, 2, 3, 4, 5, 6), low=0, high=2**63 - 1,
                                   doc='one repetition per seed in each cell')
    duration: float = param(4000.0, unit='s', low=0.001, high=1e7,
                            doc='episode length')
    snapshot_times: tuple[float, ...] = param((0.0, 1000.0, 4000.0), unit='s', low=0.0,
                                              high=1e7, doc='when to keep cue maps (fig. 3)')
    factors: tuple = param((), keyed=True,
                           doc='extra factors: dotted parameter key -> list of levels, e.g. '
                               '{mona.ir_range: [0.02, 0.05]}')
    factor_design: str = param('crossed', choices=FACTOR_DESIGNS,
                               doc="'crossed': every combination of the factors' levels; "
                                   "'one-at-a-time': each factor varies alone, the others "
                                   'keep their value in this file (a sensitivity design)')

    def __post_init__(self) -> None:
        validate(self, 'study.')

    @property
    def factor_names(self) -> tuple[str, ...]:
        """The extra factors' dotted keys, in declared order."""
        return tuple(key for key, _ in self.factors)


@dataclasses.dataclass(frozen=True)
class SwarmConfig:
    """Every parameter of a run, by section."""

    episode: EpisodeParams = dataclasses.field(default_factory=EpisodeParams)
    mona: MonaParams = dataclasses.field(default_factory=MonaParams)
    world: WorldParams = dataclasses.field(default_factory=WorldParams)
    controller: ControllerParams = dataclasses.field(default_factory=ControllerParams)
    metrics: MetricsParams = dataclasses.field(default_factory=MetricsParams)
    study: StudyParams = dataclasses.field(default_factory=StudyParams)

    def __post_init__(self) -> None:
        if self.study.factors:
            object.__setattr__(self, 'study', dataclasses.replace(
                self.study, factors=self._checked_factors()))

    def _checked_factors(self) -> tuple[tuple[str, tuple[Any, ...]], ...]:
        """The study's factors with each key checked against the schema (a renamed key
        replaced by its new one) and each level validated (and normalised, e.g. 2 -> 2.0)
        as that parameter's value."""
        checked = []
        plain = dataclasses.replace(self, study=dataclasses.replace(self.study, factors=()))
        for given, levels in self.study.factors:
            where = f'study.factors.{given}'
            try:
                key = leaf(self, given)[0]
            except ParameterError:
                key = ''
            if key in DESIGN_KEYS:
                raise ParameterError(f'{where}: {key} is set by the design; use '
                                     f'{DESIGN_KEYS[key]}')
            if not key or key.startswith('study.'):
                raise ParameterError(f'{where}: no parameter {given} (a factor is a dotted key '
                                     'of the episode, mona, world, controller or metrics '
                                     'section)')
            if len(set(levels)) != len(levels):
                raise ParameterError(f'{where} = {list(levels)!r} repeats a level')
            normalised = []
            for level in levels:
                try:
                    built = plain.with_values({key: level})
                except ParameterError as error:
                    raise ParameterError(f'{where}: {error}') from None
                normalised.append(built.value(key))
            checked.append((key, tuple(normalised)))
        return tuple(checked)

    def to_dict(self) -> dict[str, Any]:
        """Every parameter as a nested plain mapping (for JSON, YAML and bag metadata)."""
        return to_mapping(self)

    def replace(self, **sections: dict[str, Any]) -> SwarmConfig:
        """A copy with some fields changed, e.g. ``replace(episode={'seed': 3})`` or
        ``replace(controller={'beeclust': {'alpha': 3.0}})`` (nested sections are merged, not
        replaced); validated."""
        unknown = sorted(set(sections) - {f.name for f in dataclasses.fields(self)})
        if unknown:
            raise ParameterError(f'unknown parameter section {unknown[0]}')
        return from_mapping(SwarmConfig, merged(SwarmConfig, self.to_dict(), sections))

    def with_values(self, values: Mapping[str, Any]) -> SwarmConfig:
        """A copy with the parameters ``values`` (dotted key -> value, e.g.
        ``{'controller.beeclust.alpha': 3.0}``) set; validated.

        Raises:
            ParameterError: a key that names no parameter, or a bad value.
        """
        flat = {leaf(self, key)[0]: value for key, value in values.items()}
        return from_mapping(SwarmConfig, merged(SwarmConfig, self.to_dict(), unflatten(flat)))

    def value(self, key: str) -> Any:
        """The value of the parameter ``key`` (dotted, e.g. ``controller.beeclust.alpha``).

        Raises:
            ParameterError: no parameter has this key.
        """
        return leaf(self, key)[1]

    def steps(self) -> int:
        """Steps in one episode (the duration rounded up to whole steps)."""
        return steps_for(self.episode.duration, self.world.step_ns)


def current_keys(parameters: Mapping[str, Any]) -> dict[str, Any]:
    """A record's parameters (``SwarmConfig.to_dict`` form, e.g. an episode.json's) with
    the keys an older version wrote under a name since renamed moved to their current places
    (silently: the record is not the user's to change)."""
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', DeprecatedKeyWarning)
        try:
            return merged(SwarmConfig, {}, parameters)
        except ParameterError:
            return dict(parameters)


def mapping_value(parameters: Mapping[str, Any], key: str, default: Any = None) -> Any:
    """The value of the dotted ``key`` in a nested mapping of parameters (``default`` where
    it has none)."""
    value: Any = parameters
    for part in key.split('.'):
        if not isinstance(value, Mapping) or part not in value:
            return default
        value = value[part]
    return value


#: The shape of a parameter file, for the message about a file of another shape.
SKELETON = """  /**:
    ros__parameters:
      episode: {population: 30, duration: 4000.0, seed: 1}
      controller: {speed: 0.08}   # m/s
      world: {arena_side: 2.85}
  (each parameter under its section; ros_ws/config/mona_swarm.yaml has them all)"""


def _sections_of(names: Any) -> str:
    """For keys that are parameters rather than sections, where each belongs ('' if none)."""
    homes = {}
    for section in dataclasses.fields(SwarmConfig):
        for field in dataclasses.fields(section.default_factory()):  # type: ignore[misc]
            homes.setdefault(field.name, []).append(f'{section.name}.{field.name}')
    found = [' or '.join(homes[name]) for name in names if isinstance(name, str)
             and name in homes]
    return f' ({", ".join(found)}?)' if found else ''


def config_from_ros_yaml(document: Any, source: str = 'the configuration') -> SwarmConfig:
    """Build a config from a parsed ROS parameter file (its ``/**`` section).

    Raises:
        ParameterError: starting with ``source`` (once): a file of another shape (shown the
            skeleton), an unknown or a bad parameter.
    """
    if not isinstance(document, dict) or '/**' not in document:
        keys = list(document) if isinstance(document, dict) else []
        raise ParameterError(
            f"{source}: expected a ROS 2 parameter file with a '/**' section holding "
            f"'ros__parameters', each parameter under its section{_sections_of(keys)}; found "
            f'{", ".join(map(str, keys[:6])) if keys else type(document).__name__} at the '
            f'top. The skeleton:\n{SKELETON}')
    section = document['/**']
    if not isinstance(section, dict) or set(section) != {'ros__parameters'}:
        raise ParameterError(f"{source}: '/**' must hold exactly 'ros__parameters'. The "
                             f'skeleton:\n{SKELETON}')
    parameters = section['ros__parameters'] or {}
    sections = {field.name for field in dataclasses.fields(SwarmConfig)}
    if isinstance(parameters, dict) and set(parameters) - sections:
        flat = sorted(set(parameters) - sections, key=str)
        raise ParameterError(f'{source}: {", ".join(map(str, flat))} not in a section'
                             f'{_sections_of(flat)}; the sections are '
                             f'{", ".join(sorted(sections))}. The skeleton:\n{SKELETON}')
    try:
        return from_mapping(SwarmConfig, parameters)
    except ParameterError as error:
        raise ParameterError(f'{source}: {error}') from None


#: Parameters naming a file that a relative path names relative to the parameter file
#: holding it (not the current directory).
FILE_RELATIVE = ('controller.network.weights', 'controller.stand_net.weights',
                 'world.cue_file')


def file_relative_values(document: Any, folder: Path) -> dict[str, str]:
    """Each :data:`FILE_RELATIVE` parameter that ``document`` (a parsed parameter file in
    ``folder``) gives as a relative path, made absolute against ``folder``: dotted key as the
    file gives it (also a renamed one) -> path (a ``~`` path, an absolute one, an empty one
    or a malformed file is left alone)."""
    try:
        parameters = document['/**']['ros__parameters']
    except (TypeError, KeyError):
        return {}
    renamed = renamed_keys(SwarmConfig)
    found = {}
    for key in FILE_RELATIVE:
        for name in (key, *(old for old, new in renamed.items() if new == key)):
            value: Any = parameters
            for part in name.split('.'):
                value = value.get(part) if isinstance(value, dict) else None
            if isinstance(value, str) and value and not value.startswith('~') and \
                    not os.path.isabs(value):
                found[name] = os.path.normpath(folder.resolve() / value)
    return found


def file_relative_overrides(path: str | Path) -> list[str]:
    """The ``NAME:=VALUE`` overrides that hand a node the parameter file's relative file
    paths resolved (a node's ``--params-file`` cannot tell it which file a value came from;
    the launcher adds these). Empty if the file cannot be read (it is checked elsewhere)."""
    try:
        document = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError):
        return []
    return [f'{name}:={value}' for name, value in
            file_relative_values(document, Path(path).parent).items()]


def load_config(path: str | Path | None = None) -> SwarmConfig:
    """Load and validate a parameter file (the shipped default when ``path`` is None). A
    relative path of a :data:`FILE_RELATIVE` parameter is relative to the file.

    Raises:
        ParameterError: the file is missing, not YAML, or holds an unknown or bad parameter.
    """
    path = default_config_path() if path is None else Path(path)
    try:
        document = yaml.safe_load(path.read_text())
    except OSError as error:
        raise ParameterError(f'cannot read {path}: {error.strerror}') from None
    except yaml.YAMLError as error:
        raise ParameterError(f'{path} is not valid YAML: {error}') from None
    for name, value in file_relative_values(document, path.parent).items():
        *sections, key = name.split('.')
        node = document['/**']['ros__parameters']
        for section in sections:
            node = node[section]
        node[key] = value
    return config_from_ros_yaml(document, str(path))


def write_ros_yaml(config: SwarmConfig, path: str | Path) -> None:
    """Write a config as a ROS 2 parameter file that :func:`load_config` reads back."""
    parameters = config.to_dict()
    for section in parameters.values():  # rcl's YAML parser misreads an empty mapping
        for key in [k for k, v in section.items() if v == {}]:
            del section[key]
    Path(path).write_text(yaml.safe_dump({'/**': {'ros__parameters': parameters}},
                                         sort_keys=False))
