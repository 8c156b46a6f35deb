"""The whole parameter set of a run, loaded from the one YAML both runners read.

The file is a ROS 2 parameter file whose ``/**`` wildcard section holds every parameter, so
``--ros-args --params-file`` hands the same values to each node::

    /**:
      ros__parameters:
        plugins: [my_plugins.py]        # optional: plug-in files, relative to this file
        episode: {population: 30, duration: 4000.0, seed: 1}
        world: {arena_side: 2.85, ...}

The plug-ins (:mod:`mona_controller.plugins`) are loaded before the parameters are checked,
so that a controller kind, an obstacle layout or a metric they register is known then.
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from mona_controller import plugins as plugin_files
from mona_controller.controllers.params import ControllerParams
from mona_controller.keys import leaf, mapping_value, renamed_keys
from mona_controller.mappings import from_mapping, merged, to_mapping, unflatten
from mona_controller.mona import MonaParams
from mona_controller.plugins import Plugin
from mona_controller.schema import (
    NOT_A_PARAMETER,
    DeprecatedKeyWarning,
    ParameterError,
    param,
    parameter_fields,
    validate,
)
from swarm_metrics.metrics import MetricsParams
from swarm_supervisor.yaml_text import read_yaml
from swarm_world.params import WorldParams
from swarm_world.sensing.params import SensingParams
from swarm_world.timing import steps_for

#: The shipped configuration files in the source tree (the parameter file, the Fast DDS
#: profile, the profiles of Monas, the Foxglove layout).
SOURCE_CONFIG = Path(__file__).resolve().parents[3] / 'ros_ws' / 'config'
#: The shipped parameter file in the source tree (ros_ws/config/mona_swarm.yaml).
DEFAULT_CONFIG = SOURCE_CONFIG / 'mona_swarm.yaml'
#: Where an installed swarm_supervisor keeps its copies, below an install prefix.
INSTALLED_CONFIG = Path('share') / 'swarm_supervisor' / 'config'


def shipped(name: str) -> Path:
    """A shipped configuration file or folder (``name`` relative to ros_ws/config): the source
    tree's, else the installed package's (below this Python's prefix, or a colcon workspace on
    AMENT_PREFIX_PATH), so that every command works from any directory after ``pip install``.

    Raises:
        ParameterError: it is in none of them (silently doing without, e.g. with built-in
            defaults instead of the parameter file a user edits, would hide a broken install).
    """
    prefixes = [Path(sys.prefix), *(Path(p) for p in
                                     os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep)
                                     if p)]
    candidates = [SOURCE_CONFIG / name, *(prefix / INSTALLED_CONFIG / name
                                          for prefix in prefixes)]
    for candidate in candidates:
        if candidate.exists():
            return candidate
    raise ParameterError(f'the shipped {name} is missing (looked in '
                         + ', '.join(str(c) for c in candidates) + '); reinstall the '
                         'packages' + (' or pass a parameter file (--config)'
                                       if name.endswith('.yaml') else ''))


def default_config_path() -> Path:
    """The default parameter file, mona_swarm.yaml (:func:`shipped`).

    Raises:
        ParameterError: it is missing.
    """
    return shipped(DEFAULT_CONFIG.name)


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
    """Every parameter of a run, by section, and the plug-ins loaded for it (not parameters:
    :meth:`to_dict` leaves them out; episode.json records them beside the parameters)."""

    episode: EpisodeParams = dataclasses.field(default_factory=EpisodeParams)
    mona: MonaParams = dataclasses.field(default_factory=MonaParams)
    world: WorldParams = dataclasses.field(default_factory=WorldParams)
    sensing: SensingParams = dataclasses.field(default_factory=SensingParams)
    controller: ControllerParams = dataclasses.field(default_factory=ControllerParams)
    metrics: MetricsParams = dataclasses.field(default_factory=MetricsParams)
    study: StudyParams = dataclasses.field(default_factory=StudyParams)
    plugins: tuple[Plugin, ...] = dataclasses.field(default=(), metadata=NOT_A_PARAMETER)

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
                                     'of the episode, mona, world, sensing, controller or '
                                     'metrics '
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
        """Every parameter as a nested plain mapping (for JSON, YAML and bag metadata); the
        plug-ins are not in it (:meth:`plugin_records`)."""
        return to_mapping(self)

    def plugin_records(self) -> list[dict[str, str]]:
        """The plug-ins loaded for this config, as JSON records (path, SHA-256, module)."""
        return plugin_files.records(self.plugins)

    def replace(self, **sections: dict[str, Any]) -> SwarmConfig:
        """A copy with some fields changed, e.g. ``replace(episode={'seed': 3})`` or
        ``replace(controller={'beeclust': {'alpha': 3.0}})`` (nested sections are merged, not
        replaced); validated, with the same plug-ins."""
        unknown = sorted(set(sections) - {f.name for f in parameter_fields(self)})
        if unknown:
            raise ParameterError(f'unknown parameter section {unknown[0]}')
        return dataclasses.replace(
            from_mapping(SwarmConfig, merged(SwarmConfig, self.to_dict(), sections)),
            plugins=self.plugins)

    def with_values(self, values: Mapping[str, Any]) -> SwarmConfig:
        """A copy with the parameters ``values`` (dotted key -> value, e.g.
        ``{'controller.beeclust.alpha': 3.0}``) set; validated, with the same plug-ins.

        Raises:
            ParameterError: a key that names no parameter, or a bad value.
        """
        flat = {leaf(self, key)[0]: value for key, value in values.items()}
        return dataclasses.replace(
            from_mapping(SwarmConfig, merged(SwarmConfig, self.to_dict(), unflatten(flat))),
            plugins=self.plugins)

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


#: The shape of a parameter file, for the message about a file of another shape.
SKELETON = """  /**:
    ros__parameters:
      episode: {population: 30, duration: 4000.0, seed: 1}
      controller: {speed: 0.08}   # m/s
      world: {arena_side: 2.85}
  (each parameter under its section; ros_ws/config/mona_swarm.yaml has them all)"""


def _sections_of(names: Any) -> str:
    """For keys that are parameters rather than sections, where each belongs ('' if none)."""
    homes: dict[str, list[str]] = {}
    for section in parameter_fields(SwarmConfig):
        for field in dataclasses.fields(section.default_factory()):  # type: ignore[misc, operator]
            homes.setdefault(field.name, []).append(f'{section.name}.{field.name}')
    found = [' or '.join(homes[name]) for name in names if isinstance(name, str)
             and name in homes]
    return f' ({", ".join(found)}?)' if found else ''


def config_from_ros_yaml(document: Any, source: str = 'the configuration',
                         folder: Path | None = None) -> SwarmConfig:
    """Build a config from a parsed ROS parameter file (its ``/**`` section), after loading the
    installed plug-ins and those its ``plugins`` list names (relative to ``folder``, the
    file's; default the current directory).

    Raises:
        ParameterError: starting with ``source`` (once): a file of another shape (shown the
            skeleton), a plug-in that cannot be loaded, an unknown or a bad parameter.
    """
    if not isinstance(document, dict) or '/**' not in document:
        keys = list(document) if isinstance(document, dict) else []
        raise ParameterError(
            f"{source}: expected a ROS 2 parameter file with a '/**' section holding "
            f"'ros__parameters', each parameter under its section{_sections_of(keys)}; found "
            f'{", ".join(map(str, keys[:6])) if keys else type(document).__name__} at the '
            f'top. The skeleton:\n{SKELETON}')
    others = [str(key) for key in document if key != '/**']
    if others:  # a node's own section: the nodes would read it, the embedded runner not
        raise ParameterError(f"{source}: {', '.join(others)}: only the '/**' section is read, "
                             "by both runners: move these parameters under /**: ros__parameters")
    section = document['/**']
    if not isinstance(section, dict) or set(section) != {'ros__parameters'}:
        raise ParameterError(f"{source}: '/**' must hold exactly 'ros__parameters'. The "
                             f'skeleton:\n{SKELETON}')
    parameters = section['ros__parameters'] or {}
    sections = {field.name for field in parameter_fields(SwarmConfig)}
    try:
        if isinstance(parameters, dict) and plugin_files.KEY in parameters:
            parameters = dict(parameters)
            paths = plugin_files.resolve(parameters.pop(plugin_files.KEY) or [], folder)
        else:
            paths = []
        loaded = plugin_files.load(paths)
    except ParameterError as error:
        raise ParameterError(f'{source}: {error}') from None
    if isinstance(parameters, dict) and set(parameters) - sections:
        flat = sorted(set(parameters) - sections, key=str)
        raise ParameterError(f'{source}: {", ".join(map(str, flat))} not in a section'
                             f'{_sections_of(flat)}; the sections are '
                             f'{", ".join(sorted(sections))}. The skeleton:\n{SKELETON}')
    try:
        return dataclasses.replace(from_mapping(SwarmConfig, parameters), plugins=loaded)
    except ParameterError as error:
        raise ParameterError(f'{source}: {error}') from None


#: Parameters naming a file: a relative path is relative to the parameter file giving it.
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
            value = mapping_value(parameters, name)
            if isinstance(value, str) and value and not value.startswith('~') and \
                    not os.path.isabs(value):
                found[name] = os.path.normpath(folder.resolve() / value)
    return found


def file_relative_overrides(path: str | Path) -> list[str]:
    """The ``NAME:=VALUE`` overrides that hand a node the parameter file's relative file
    paths resolved, the plug-in files' too (a node's ``--params-file`` cannot tell it which
    file a value came from; the launcher adds these). Empty if the file cannot be read (it is
    checked elsewhere)."""
    try:
        document = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError):
        return []
    overrides = [f'{name}:={value}' for name, value in
                 file_relative_values(document, Path(path).parent).items()]
    try:
        paths = plugin_files.resolve(document['/**']['ros__parameters'][plugin_files.KEY],
                                     Path(path).parent)
    except (TypeError, KeyError, ParameterError):
        return overrides
    return overrides + [plugins_override(paths)] if paths else overrides


def plugins_override(paths: list[str]) -> str:
    """The ``plugins:=[...]`` override naming plug-in files (absolute paths, as a YAML list a
    ROS parameter override parses)."""
    return f'{plugin_files.KEY}:={json.dumps(paths)}'


def load_config(path: str | Path | None = None) -> SwarmConfig:
    """Load and validate a parameter file (the shipped default when ``path`` is None). A
    relative path of a :data:`FILE_RELATIVE` parameter is relative to the file.

    Raises:
        ParameterError: the file is missing, not YAML, gives a key twice in one mapping
            (:mod:`swarm_supervisor.yaml_text`), or holds an unknown or bad parameter.
    """
    path = default_config_path() if path is None else Path(path)
    document = read_yaml(path)
    for name, value in file_relative_values(document, path.parent).items():
        where, _, key = name.rpartition('.')  # the section holding it (it gives the key)
        mapping_value(document['/**']['ros__parameters'], where)[key] = value
    return config_from_ros_yaml(document, str(path), path.parent)


def write_ros_yaml(config: SwarmConfig, path: str | Path) -> None:
    """Write a config as a ROS 2 parameter file that :func:`load_config` reads back (its
    plug-in files listed by their absolute paths)."""
    parameters: dict[str, Any] = config.to_dict()
    for section in parameters.values():  # rcl's YAML parser misreads an empty mapping
        for key in [k for k, v in section.items() if v == {}]:
            del section[key]
    files = [plugin.path for plugin in config.plugins if plugin.origin == plugin_files.FILE]
    if files:
        parameters = {plugin_files.KEY: files, **parameters}
    Path(path).write_text(yaml.safe_dump({'/**': {'ros__parameters': parameters}},
                                         sort_keys=False))
