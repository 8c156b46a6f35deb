"""Lazy public faces for sub-packages: a name is imported from its module on first use.

A sub-package's ``__init__`` lists its public names and the module each lives in; importing
the package imports none of them, so ``from swarm_supervisor.study import specs`` does not
pull in pandas, ``swarm_supervisor.analysis`` does not load statsmodels until a table is
analysed, ``swarm_world`` does not compile a kernel until one is used, and
``mona_controller.controllers`` does not import a kind's module until it is used. Here, at the
bottom of the packages, so that every package's faces use it::

    __getattr__, __dir__ = lazy_exports(__name__, {'run_study': 'run', 'tidy_table': 'table'})
    __all__ = [...]
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any


def lazy_exports(package: str, where: Mapping[str, str], here: Sequence[str] = ()
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """A module ``__getattr__`` and ``__dir__`` for ``package`` whose public names live in
    its modules: ``where`` maps each name to its module's name within the package; ``here``
    names the public names the package's ``__init__`` defines itself."""

    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is None:
            raise AttributeError(f'module {package!r} has no attribute {name!r}')
        return getattr(importlib.import_module(f'{package}.{module}'), name)

    def __dir__() -> list[str]:
        return sorted([*where, *here])

    return __getattr__, __dir__


def moved(old: str, *new: str) -> Callable[[str], Any]:
    """A module ``__getattr__`` for a module that moved: each name is looked up in the
    modules ``new``, in order, with a DeprecationWarning naming where it lives now."""

    def __getattr__(name: str) -> Any:
        if name.startswith('__'):
            raise AttributeError(f'module {old!r} has no attribute {name!r}')
        for module in new:
            found = importlib.import_module(module)
            if hasattr(found, name):
                warnings.warn(f'{old}.{name} moved to {module}.{name}', DeprecationWarning,
                              stacklevel=2)
                return getattr(found, name)
        raise AttributeError(f'module {old!r} has no attribute {name!r} (it moved to '
                             f'{" or ".join(new)})')

    return __getattr__


class _MovedModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports each moved module's old name as a module that forwards its names
    (:func:`moved`): no file stays behind at the old path."""

    def __init__(self, moves: Mapping[str, tuple[str, ...]]) -> None:
        self.moves = dict(moves)

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> Any:
        """A spec for an old name this finder knows, else None (the next finder's turn)."""
        if fullname not in self.moves:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec: Any) -> None:
        """The default module."""

    def exec_module(self, module: Any) -> None:
        """Make the module forward its names to where they moved."""
        new = self.moves[module.__name__]
        module.__doc__ = f'Moved to {" and ".join(new)} (this name works for one release).'
        module.__getattr__ = moved(module.__name__, *new)


def moved_modules(package: str, moves: Mapping[str, Sequence[str]]) -> None:
    """Keep the old names of the modules of ``package`` that moved importable, for one
    release: ``moves`` maps an old module name to the module(s) its names now live in (both
    within ``package``), e.g. ``{'controller': ['controllers.beeclust']}``. Call it in the
    package's ``__init__``; an old name's attribute warns (DeprecationWarning) where it lives
    now."""
    sys.meta_path.append(_MovedModules({
        f'{package}.{old}': tuple(f'{package}.{name}' for name in new)
        for old, new in moves.items()}))
