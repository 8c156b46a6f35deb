"""Plug-ins: a user's own metrics, controller kinds and obstacle layouts, named once for every
process of a run (docs/extending.md).

A plug-in is a Python module that registers what it adds when it is imported:
``swarm_metrics.metrics.register`` (a metric), ``mona_controller.controllers.
register_controller`` (a controller kind) and ``swarm_world.layouts.register_layout`` (an
obstacle layout). There are two ways to name one, and both reach every process of a run (the
study's workers, every node of the node system):

- **a file**: the parameter file's ``plugins:`` list, each path absolute or relative to the
  parameter file. A file is imported under a name of its own (:func:`module_name`), so that
  files in different folders may share a name and the user's folder stays off ``sys.path``.
- **an installed package**: an entry point in the group :data:`ENTRY_POINTS` (``name =
  package.module``) in its packaging metadata; every process that loads plug-ins imports it.

Each loaded plug-in is a :class:`Plugin` record (its file, that file's SHA-256, the module it
became), so that a run records exactly which code it ran, and another process can load the
very same code (:func:`ensure`, which refuses a file that changed since). A file's digest is
of the bytes that were executed; a module it imports in turn is not covered.

``MONA_SWARM_METRICS`` (:data:`METRICS_VARIABLE`), comma-separated module names on the Python
path, is a deprecated alias: its modules load as plug-ins too, with a warning.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import importlib.metadata
import importlib.util
import os
import re
import sys
import traceback
import warnings
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

from mona_controller.schema import ParameterError

#: The entry-point group of installed plug-ins: ``name = package.module``.
ENTRY_POINTS = 'mona_swarm.plugins'
#: The deprecated environment variable naming metric modules (comma-separated).
METRICS_VARIABLE = 'MONA_SWARM_METRICS'
#: The parameter-file key listing plug-in files (under ``ros__parameters``, beside the
#: sections), and the ROS parameter every node reads them from.
KEY = 'plugins'
#: Where the documentation explains plug-ins.
RECIPES = 'docs/extending.md'
#: The origins of a plug-in (:attr:`Plugin.origin`).
FILE, ENTRY_POINT, VARIABLE = 'file', 'entry point', METRICS_VARIABLE


class PluginError(ParameterError):
    """A plug-in that cannot be found, read or imported, or that changed since its run began
    (a ParameterError: the commands report it in one line with exit status 2)."""


@dataclasses.dataclass(frozen=True)
class Plugin:
    """One loaded plug-in, as a run records it."""

    path: str  #: the module's file (absolute)
    sha256: str  #: the SHA-256 of that file ('' for a module without a file)
    module: str  #: the module it was imported as
    origin: str = FILE  #: :data:`FILE`, :data:`ENTRY_POINT` or :data:`VARIABLE`
    name: str = ''  #: an entry point's name

    def to_dict(self) -> dict[str, str]:
        """The record as a JSON mapping (episode.json, the bag's announcement)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, record: Mapping[str, Any]) -> Plugin:
        """A record read back.

        Raises:
            PluginError: not a plug-in record.
        """
        try:
            return cls(str(record['path']), str(record['sha256']), str(record['module']),
                       str(record.get('origin', FILE)), str(record.get('name', '')))
        except (TypeError, KeyError, AttributeError) as error:
            raise PluginError(f'not a plug-in record: {record!r} ({error})') from None


#: Every plug-in loaded in this process, by module name.
_LOADED: dict[str, Plugin] = {}


def digest(path: str | Path) -> str:
    """The SHA-256 of a file, as hex."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def module_name(path: str | Path) -> str:
    """The module a plug-in file is imported as: its stem made an identifier, and a hash of its
    absolute path, so that two files of one name in different folders stay apart and every
    process gives a file the same name (a class in it pickles between processes)."""
    resolved = str(Path(path).resolve())
    stem = re.sub(r'\W', '_', Path(resolved).stem)
    return f'mona_swarm_plugin_{stem}_{hashlib.sha1(resolved.encode()).hexdigest()[:10]}'


def resolve(paths: Sequence[Any], base: Path | None, where: str = KEY) -> list[str]:
    """The plug-in paths of a parameter file (``base``: its folder), absolute.

    Raises:
        PluginError: ``paths`` is not a list of non-empty strings.
    """
    if isinstance(paths, str) or not isinstance(paths, Sequence) or not all(
            isinstance(path, str) and path.strip() for path in paths):
        raise PluginError(f'{where} = {paths!r}: expected a list of plug-in files (paths '
                          f'relative to the parameter file), e.g. [my_plugins.py]; '
                          f'{RECIPES}')
    folder = Path.cwd() if base is None else base
    return [os.path.normpath(folder.resolve() / os.path.expanduser(path)) for path in paths]


def _failure(error: BaseException, path: str) -> str:
    """An import error in one line: its type and message, and the plug-in's line."""
    lines = [frame.lineno for frame in traceback.extract_tb(error.__traceback__)
             if frame.filename == path]
    at = f' (line {lines[-1]})' if lines else ''
    return f'{type(error).__name__}: {error}{at}'


def _module_failure(error: BaseException, module: str) -> str:
    """A module's import error in one line: its type and message, the deepest line of the
    user's code (a syntax error names its own), and what to do."""
    frames = [] if isinstance(error, SyntaxError) else [
        frame for frame in traceback.extract_tb(error.__traceback__)
        if not frame.filename.startswith('<frozen') and frame.filename != __file__]
    at = f' ({frames[-1].filename}, line {frames[-1].lineno})' if frames else ''
    missing = isinstance(error, ModuleNotFoundError) and error.name == module.split('.')[0]
    hint = 'install it, or put its folder on PYTHONPATH' if missing else 'fix it, or leave it out'
    return f'{type(error).__name__}: {error}{at}; {hint}'


def load_file(path: str | Path, where: str = KEY) -> Plugin:
    """Import a plug-in file (once per process) and return its record.

    Raises:
        PluginError: naming ``where`` and the file: it is missing or unreadable, or its
            import fails (the error and its line).
    """
    path = os.path.normpath(Path(path).resolve())
    name = module_name(path)
    if name in _LOADED:
        return _LOADED[name]
    try:
        source = Path(path).read_bytes()
    except OSError as error:
        raise PluginError(f'{where}: cannot read the plug-in {path}: '
                          f'{error.strerror or error}; {RECIPES}') from None
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None  # a path always has a spec
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:  # the very bytes digested are the bytes run
        exec(compile(source, path, 'exec'), module.__dict__)  # noqa: S102
    except Exception as error:  # the plug-in's own code: any error it raises
        del sys.modules[name]
        raise PluginError(f'{where}: the plug-in {path} fails to import: '
                          f'{_failure(error, path)}') from None
    record = Plugin(path, hashlib.sha256(source).hexdigest(), name)
    _LOADED[name] = record
    return record


def _import(module: str, origin: str, name: str = '') -> Plugin:
    """Import an installed plug-in module (once per process) and return its record."""
    if module in _LOADED:
        return _LOADED[module]
    label = f'{origin} {name}' if name else origin
    try:
        imported: ModuleType = importlib.import_module(module)
    except Exception as error:  # the plug-in's own code: any error it raises
        raise PluginError(f'{label}: cannot import {module!r}: {_module_failure(error, module)}'
                          ) from None
    file = getattr(imported, '__file__', None) or ''
    record = Plugin(os.path.abspath(file) if file else '', digest(file) if file else '', module,
                    origin, name)
    _LOADED[module] = record
    return record


def installed() -> tuple[Plugin, ...]:
    """Import every installed plug-in: the entry points of :data:`ENTRY_POINTS`, then the
    modules of :data:`METRICS_VARIABLE` (deprecated, with a warning)."""
    found = [_import(point.module, ENTRY_POINT, point.name) for point in
             sorted(importlib.metadata.entry_points(group=ENTRY_POINTS), key=lambda p: p.name)]
    modules = [m.strip() for m in os.environ.get(METRICS_VARIABLE, '').split(',') if m.strip()]
    if modules:
        warnings.warn(f'{METRICS_VARIABLE} is deprecated: list the metric files under '
                      f"'{KEY}:' in the parameter file ({RECIPES}, \"A metric\")",
                      FutureWarning, stacklevel=2)
    return tuple(found + [_import(module, VARIABLE) for module in modules])


def load(paths: Iterable[str | Path] = (), where: str = KEY) -> tuple[Plugin, ...]:
    """Load the installed plug-ins (:func:`installed`) and the files ``paths`` (absolute, or
    relative to the current directory), in that order; the records of all of them.

    Raises:
        PluginError: a plug-in is missing or fails to import.
    """
    return installed() + tuple(load_file(path, where) for path in paths)


def ensure(records: Iterable[Plugin]) -> tuple[Plugin, ...]:
    """Load the plug-ins another process recorded, the very same code: a file at its recorded
    path, an installed module by name (a study's worker, an analysis of a record).

    Returns:
        Their records in this process (equal to ``records``).

    Raises:
        PluginError: a plug-in is missing, fails to import, or its file's SHA-256 is not the
            recorded one (it changed since the run began).
    """
    done = []
    for record in records:
        if record.origin == FILE:
            loaded = load_file(record.path)
        else:
            loaded = _import(record.module, record.origin, record.name)
        if record.sha256 and loaded.sha256 != record.sha256:
            raise PluginError(f'the plug-in {loaded.path} is not the code the run recorded '
                              f'(SHA-256 {loaded.sha256[:12]}..., recorded '
                              f'{record.sha256[:12]}...): it changed since')
        done.append(loaded)
    return tuple(done)


def loaded() -> tuple[Plugin, ...]:
    """Every plug-in loaded in this process, in load order."""
    return tuple(_LOADED.values())


def records(plugins: Iterable[Plugin]) -> list[dict[str, str]]:
    """Plug-ins as JSON records (:meth:`Plugin.to_dict`)."""
    return [plugin.to_dict() for plugin in plugins]


def from_records(documents: Any, where: str = KEY) -> tuple[Plugin, ...]:
    """Plug-in records read back from JSON (none if ``documents`` is None).

    Raises:
        PluginError: not a list of records.
    """
    if documents is None:
        return ()
    if not isinstance(documents, list) or not all(isinstance(d, Mapping) for d in documents):
        raise PluginError(f'{where}: not a list of plug-in records: {documents!r}')
    return tuple(Plugin.from_dict(document) for document in documents)
