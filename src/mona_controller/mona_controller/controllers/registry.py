"""The registry of controller kinds: the one place that says which kinds there are.

``controller.kind`` names an entry of :data:`CONTROLLERS`, a ``'module:Class'`` imported on
first use (:func:`load`), so that the table lists every kind without importing its module.
The table grows at run time through :func:`register_controller` (this process and those it
forks) and the :data:`ENTRY_POINTS` of installed packages (every process: a study's workers,
every node). A kind's class declares its own parameters and states
(:class:`mona_controller.controllers.base.Controller`).
"""

from __future__ import annotations

import importlib
import importlib.metadata
from typing import Any

#: Every controller kind, by the name ``controller.kind`` takes: ``'module:Class'``. Adding a
#: kind is adding one line here, or :func:`register_controller`, or an entry point of
#: :data:`ENTRY_POINTS` in one's own package.
CONTROLLERS: dict[str, str] = {
    'beeclust': 'mona_controller.controllers.beeclust:SwarmController',
    'network': 'mona_controller.controllers.network:NetworkController',
    'solo': 'mona_controller.controllers.solo:SoloController',
    'stand_net': 'mona_controller.controllers.stand_net:StandNetController',
}
#: The entry-point group through which an installed package adds controller kinds
#: (``name = 'module:Class'``): every process (a study's workers, every node) sees them.
ENTRY_POINTS = 'mona_swarm.controllers'


def register_controller(kind: str, target: str | type) -> None:
    """Add a controller kind, ``target`` being the class or ``'module:Class'`` (for this
    process; a plug-in, :mod:`mona_controller.plugins`, does it in every process of a run).

    Raises:
        ValueError: the kind is taken by another class, or ``target`` is not 'module:Class'.
    """
    if isinstance(target, type):
        target = f'{target.__module__}:{target.__qualname__}'
    module, colon, name = target.partition(':')
    if not (kind.isidentifier() and module and colon and name.isidentifier()):
        raise ValueError(f"controller {kind!r}: {target!r} is not 'module:Class' (or the kind "
                         'is not a name)')
    if CONTROLLERS.get(kind, target) != target:
        raise ValueError(f'controller kind {kind!r} is already {CONTROLLERS[kind]}')
    CONTROLLERS[kind] = target


def load(kind: str) -> Any:
    """The class registered as ``kind``, imported on first use.

    Raises:
        KeyError: no such kind.
        ImportError: its module cannot be imported (naming the kind), or lacks the class.
    """
    module, _, name = CONTROLLERS[kind].partition(':')
    try:
        return getattr(importlib.import_module(module), name)
    except (ImportError, AttributeError) as error:
        raise ImportError(f'controller kind {kind!r} ({CONTROLLERS[kind]}) cannot be loaded: '
                          f'{error}') from error


for _point in importlib.metadata.entry_points(group=ENTRY_POINTS):
    CONTROLLERS.setdefault(_point.name, _point.value)
