"""Obstacle layouts by name: ``world.layout`` picks one that a plug-in registered.

A layout is a function of the world's parameters (its arena side, its sources, ...) that
returns obstacles as ``world.obstacles`` spells them: a mapping of names to ``[numbers...]``
or ``[kind, numbers...]`` (:mod:`swarm_world.arena`). Registered once
(:func:`register_layout`, in a plug-in: :mod:`mona_controller.plugins`), it is a parameter
value like any other: both runners and every node build the same obstacles from it, a study
may sweep it (``study.factors: {world.layout: ['', ring]}``), and the records name it.
Obstacles of ``world.obstacles`` are added to the layout's (docs/extending.md, "An obstacle
layout").
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from mona_controller.schema import ParameterError

# A layout takes the world section (swarm_world.params.WorldParams), typed Any here: params
# imports this module, and no two modules name each other, not even for annotations.
WorldParams = Any

#: A layout: the world's parameters -> obstacle name -> [kind, numbers...] or [numbers...].
Layout = Callable[['WorldParams'], Mapping[str, Sequence[Any]]]
#: Every registered layout, by the name ``world.layout`` takes.
LAYOUTS: dict[str, Layout] = {}
#: Where the recipe is.
RECIPE = 'docs/extending.md#an-obstacle-layout'


def register_layout(name: str, build: Layout) -> Layout:
    """Register ``build`` as the layout ``name`` (in this process; a plug-in does it in every
    process of a run).

    Returns:
        ``build`` (so a module can keep it).

    Raises:
        ValueError: ``name`` is empty, or another function has that name.
    """
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f'a layout name must be an identifier, not {name!r}')
    if LAYOUTS.get(name, build) is not build:
        raise ValueError(f'a layout named {name!r} is registered already')
    LAYOUTS[name] = build
    return build


def layout_obstacles(name: str, world: WorldParams) -> tuple[tuple[str, tuple[Any, ...]], ...]:
    """The obstacles layout ``name`` gives ``world``, as (name, values) pairs.

    Raises:
        ParameterError: naming ``world.layout``: no such layout, it fails, or it returns
            something other than a mapping of names to lists.
    """
    where = f'world.layout = {name!r}'
    if name not in LAYOUTS:
        known = ', '.join(map(repr, LAYOUTS)) or 'none'
        raise ParameterError(f'{where} is not a registered layout (registered: {known}); a '
                             f'layout of your own is a plug-in: {RECIPE}')
    try:
        given = LAYOUTS[name](world)
    except ParameterError as error:
        raise ParameterError(f'{where}: {error}') from None
    except Exception as error:  # the plug-in's own code: any error it raises
        raise ParameterError(f'{where} fails: {type(error).__name__}: {error}') from None
    if not isinstance(given, Mapping) or not all(
            isinstance(key, str) and isinstance(values, (list, tuple))
            for key, values in given.items()):
        raise ParameterError(f'{where} returned {type(given).__name__}, not a mapping of '
                             'obstacle names to [kind, numbers...] lists')
    return tuple((key, tuple(values)) for key, values in given.items())
