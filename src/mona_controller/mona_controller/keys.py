"""Dotted parameter keys: the parameter a key names below any section, and the renamed keys.

A key names a parameter through its sections (``controller.beeclust.alpha``: the controller
section, its ``beeclust`` section, the field ``alpha``); :func:`leaf` follows it, through the
named sections of a :func:`~mona_controller.schema.sections` field too, and through a key a
section renamed (``RENAMED``, with a :class:`~mona_controller.schema.DeprecatedKeyWarning`).
"""

from __future__ import annotations

import dataclasses
import warnings
from typing import Any

from mona_controller.schema import (
    DeprecatedKeyWarning,
    ParameterError,
    Spec,
    named_sections,
    spec_of,
)


def renamed_keys(cls: type, prefix: str = '') -> dict[str, str]:
    """Every renamed key below section ``cls`` (its own ``RENAMED`` and its sections'), as
    old dotted key -> new dotted key."""
    found = {f'{prefix}{old}': f'{prefix}{new}'
             for old, new in getattr(cls, 'RENAMED', {}).items()}
    for field in dataclasses.fields(cls):
        factory = field.default_factory
        if spec_of(field) is None and 'sections' not in field.metadata and callable(factory):
            found.update(renamed_keys(type(factory()), f'{prefix}{field.name}.'))
    for name, (_, section) in named_sections(cls).items():
        found.update(renamed_keys(section, f'{prefix}{name}.'))
    return found


def leaf(section: Any, key: str) -> tuple[str, Any, Spec]:
    """The parameter ``key`` (dotted, below ``section``, e.g. a ``SwarmConfig`` and
    ``controller.beeclust.alpha``) as (its key, its value, its spec). A renamed key is
    followed to its new place (with a :class:`DeprecatedKeyWarning`): the key returned is
    the new one.

    Raises:
        ParameterError: no parameter has this key.
    """
    parts, node = key.split('.'), section
    done: list[str] = []
    while parts:
        name = parts.pop(0)
        renamed = getattr(type(node), 'RENAMED', {}).get(name)
        if renamed is not None:
            where = '.'.join(done + [name])
            warnings.warn(f'{where} is deprecated: use {".".join(done + [renamed])}',
                          DeprecatedKeyWarning, stacklevel=2)
            name, *rest = renamed.split('.')
            parts = rest + parts
        done.append(name)
        fields = {f.name: f for f in dataclasses.fields(node)} if \
            dataclasses.is_dataclass(node) else {}
        named = named_sections(node) if fields else {}
        if name in named:
            node = dict(getattr(node, named[name][0]))[name]
            continue
        field = fields.get(name)
        if field is None or 'sections' in field.metadata:
            break
        spec = spec_of(field)
        if spec is None:
            node = getattr(node, name)
            continue
        if parts:
            break
        return '.'.join(done), getattr(node, name), spec
    raise ParameterError(f'no parameter {key}')
