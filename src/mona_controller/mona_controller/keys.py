"""Dotted parameter keys: the parameter a key names below any section, and the keys that
were renamed or moved.

A key names a parameter through its sections (``controller.beeclust.alpha``: the controller
section, its ``beeclust`` section, the field ``alpha``); :func:`leaf` follows it, through the
named sections of a :func:`~mona_controller.schema.sections` field too, through a key a
section renamed (``RENAMED``) and through one that moved to another section (``MOVED``), with
a :class:`~mona_controller.schema.DeprecatedKeyWarning`.

A section lists the keys it renamed in ``RENAMED`` (old name -> new dotted path below it);
:func:`renamed` moves them in a mapping of that section. A key may also move to another
section: the section it left lists it in ``MOVED`` (its name -> the new dotted key), the
section it joined in ``FORMERLY`` (its name -> the old dotted key). The old key still works
for one release: :func:`moved_keys` lists them, :func:`relocate` moves them in a mapping of
sections, with a :class:`~mona_controller.schema.DeprecatedKeyWarning` naming the new key.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping
from typing import Any

from mona_controller.schema import (
    DeprecatedKeyWarning,
    ParameterError,
    Spec,
    named_sections,
    parameter_fields,
    section_mapping,
    spec_of,
)


def renamed_keys(cls: type, prefix: str = '') -> dict[str, str]:
    """Every renamed key below section ``cls`` (its own ``RENAMED`` and its sections'), as
    old dotted key -> new dotted key."""
    found = {f'{prefix}{old}': f'{prefix}{new}'
             for old, new in getattr(cls, 'RENAMED', {}).items()}
    for field in parameter_fields(cls):
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
    key = moved_key(type(section), key)  # a key that moved to another section
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
        fields = {f.name: f for f in parameter_fields(node)} if \
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


def mapping_value(parameters: Mapping[str, Any], key: str, default: Any = None) -> Any:
    """The value of the dotted ``key`` in a nested mapping of parameters (``default`` where
    it has none)."""
    value: Any = parameters
    for part in key.split('.'):
        if not isinstance(value, Mapping) or part not in value:
            return default
        value = value[part]
    return value


def moved_keys(cls: type, prefix: str = '') -> dict[str, str]:
    """Every key that moved out of or into section ``cls`` or a section in it (``MOVED``,
    ``FORMERLY``), as old dotted key -> new dotted key (keys of the parameter file: a
    section's ``prefix`` is where it sits in the file)."""
    found = {f'{prefix}{name}': new for name, new in getattr(cls, 'MOVED', {}).items()}
    found.update({old: f'{prefix}{name}' for name, old in getattr(cls, 'FORMERLY', {}).items()})
    for field in parameter_fields(cls):
        factory = field.default_factory
        if spec_of(field) is None and 'sections' not in field.metadata and callable(factory):
            found.update(moved_keys(type(factory()), f'{prefix}{field.name}.'))
    return found


def relocate(parameters: Mapping[str, Any], moved: Mapping[str, str], *,
             warn: bool = True) -> dict[str, Any]:
    """A copy of ``parameters`` (a mapping of sections, as a parameter file holds them) with
    each key of ``moved`` it gives (old dotted key -> new) at its new place, with a
    :class:`DeprecatedKeyWarning` naming the new key unless ``warn`` is False (a record
    written before the move: nobody to tell).

    Raises:
        ParameterError: a key given both under its old and its new name.
    """
    out = {name: dict(value) if isinstance(value, Mapping) else value
           for name, value in parameters.items()}
    for old, new in moved.items():
        (section, name), (new_section, new_name) = old.split('.', 1), new.split('.', 1)
        if not isinstance(out.get(section), dict) or name not in out[section]:
            continue
        if new_name in (out.get(new_section) or {}):
            raise ParameterError(f'{old} and {new} are both given: give {new} only')
        if warn:
            warnings.warn(f'{old} is deprecated: use {new}', DeprecatedKeyWarning,
                          stacklevel=2)
        value = out[section].pop(name)
        out[new_section] = {**(out.get(new_section) or {}), new_name: value}
    return out


def moved_key(cls: type, key: str) -> str:
    """The key a dotted parameter key of section ``cls`` names now: itself, or the new key
    of a key that moved (with a :class:`DeprecatedKeyWarning`)."""
    new = moved_keys(cls).get(key)
    if new is None:
        return key
    warnings.warn(f'{key} is deprecated: use {new}', DeprecatedKeyWarning, stacklevel=2)
    return new


def renamed(cls: type, mapping: dict[str, Any], prefix: str) -> dict[str, Any]:
    """``mapping`` with the keys ``cls.RENAMED`` lists moved to their new places (warned)."""
    for old, new in getattr(cls, 'RENAMED', {}).items():
        if old not in mapping:
            continue
        warnings.warn(f'{prefix}{old} is deprecated: use {prefix}{new}', DeprecatedKeyWarning,
                      stacklevel=3)
        value = mapping.pop(old)
        *parents, last = new.split('.')
        node = mapping
        for part in parents:
            node[part] = dict(section_mapping(node.get(part, {}), prefix + part))
            node = node[part]
        if last in node:
            raise ParameterError(f'{prefix}{old} and {prefix}{new} are both given: give '
                                 f'{prefix}{new} only')
        node[last] = value
    return mapping
