"""Lazy public faces for sub-packages: a name is imported from its module on first use.

A sub-package's ``__init__`` lists its public names and the module each lives in; importing
the package imports none of them, so ``from swarm_supervisor.study import specs`` does not
pull in pandas, ``swarm_supervisor.analysis`` does not load statsmodels until a table is
analysed, and ``swarm_world`` does not compile a kernel until one is used. Here, at the
bottom of the packages, so that every package's faces use it::

    __getattr__, __dir__ = lazy_exports(__name__, {'run_study': 'run', 'tidy_table': 'table'})
    __all__ = [...]
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, where: Mapping[str, str]
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """A module ``__getattr__`` and ``__dir__`` for ``package`` whose public names live in
    its modules: ``where`` maps each name to its module's name within the package."""

    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is None:
            raise AttributeError(f'module {package!r} has no attribute {name!r}')
        return getattr(importlib.import_module(f'{package}.{module}'), name)

    def __dir__() -> list[str]:
        return sorted(where)

    return __getattr__, __dir__
