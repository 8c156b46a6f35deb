"""Parameter sections to and from plain mappings (a parameter file, JSON, ROS parameters).

:func:`from_mapping` builds a section from a (nested) mapping: missing keys take their
defaults, unknown keys are rejected, renamed and moved keys go to their new places with a
:class:`~mona_controller.schema.DeprecatedKeyWarning` (:mod:`mona_controller.keys`);
:func:`merged` applies changes to a mapping of a section; :func:`to_mapping` is the inverse
(for JSON or YAML), :func:`leaves` and :func:`flat_fields` the parameters by dotted key (for
the nodes to declare), :func:`unflatten` dotted keys back to sections, :func:`differences`
how another node's mapping differs from a section.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any, TypeVar

from mona_controller import schema
from mona_controller.keys import moved_keys, relocate, renamed

T = TypeVar('T')


def from_mapping(cls: type[T], mapping: Mapping[str, Any] | None, prefix: str = '') -> T:
    """Build section ``cls`` from a nested mapping; missing keys take their defaults. A key
    the section renamed (``RENAMED``) is moved to its new place, with a
    :class:`DeprecatedKeyWarning`.

    Raises:
        ParameterError: for an unknown key (listing the known ones), a bad value, or a key
            given under both its old and its new name.
    """
    mapping = dict(mapping or {})
    moved = moved_keys(cls) if not prefix else {}
    if moved:  # a whole parameter file: keys that moved go to their new sections
        mapping = relocate(mapping, moved)
    mapping = renamed(cls, mapping, prefix)
    known = {f.name: f for f in schema.parameter_fields(cls) if 'sections' not in f.metadata}
    named = schema.named_sections(cls)
    unknown = sorted(set(mapping) - set(known) - set(named))
    if unknown:
        new = getattr(cls, 'MOVED', {}).get(unknown[0])
        if new:
            raise schema.ParameterError(f'{prefix}{unknown[0]} moved to {new}: give it there')
        raise schema.ParameterError(f'unknown parameter {prefix}{unknown[0]}; known in '
                             f'{prefix or "the top level"}: '
                             f'{", ".join(sorted({*known, *named}))}')
    values: dict[str, Any] = {}
    for name, value in mapping.items():
        if name in named:
            held, section = named[name]
            values.setdefault(held, []).append((name, from_mapping(
                section, schema.section_mapping(value, prefix + name), f'{prefix}{name}.')))
            continue
        field = known[name]
        if schema.spec_of(field) is None:
            factory = field.default_factory
            assert callable(factory), f'{prefix}{name}: a section field needs a default_factory'
            value = from_mapping(type(factory()), schema.section_mapping(value, prefix + name),
                                 f'{prefix}{name}.')
        values[name] = value
    try:
        return cls(**values)
    except schema.ParameterError as error:
        if prefix and not str(error).startswith(prefix):
            raise schema.ParameterError(prefix + str(error)) from None
        raise


def merged(cls: type, base: Mapping[str, Any], changes: Mapping[str, Any],
           prefix: str = '') -> dict[str, Any]:
    """``base`` (a mapping of section ``cls``, as :func:`to_mapping` gives it) with
    ``changes`` applied: a section in both is merged key by key, anything else replaced
    (a mapping-valued parameter such as ``study.factors`` too); renamed keys and keys that
    moved to another section are moved (with a :class:`DeprecatedKeyWarning`)."""
    if not prefix:  # a whole parameter file: keys that moved go to their new sections
        changes = relocate(changes, moved_keys(cls))
    out = dict(base)
    named = schema.named_sections(cls)
    fields = {f.name: f for f in schema.parameter_fields(cls)}
    for key, value in renamed(cls, dict(changes), prefix).items():
        field = fields.get(key)
        sub = named[key][1] if key in named else \
            type(field.default_factory()) if field is not None and schema.spec_of(field) is None \
            and callable(field.default_factory) else None
        if sub is not None and isinstance(value, Mapping):
            below = out.get(key)
            out[key] = merged(sub, below if isinstance(below, Mapping) else {}, value,
                              f'{prefix}{key}.')
        else:
            out[key] = value
    return out


def to_mapping(section: Any) -> dict[str, Any]:
    """A nested plain mapping of a section (tuples become lists), e.g. for JSON or YAML."""
    out: dict[str, Any] = {}
    for field in schema.parameter_fields(section):
        value = getattr(section, field.name)
        spec = schema.spec_of(field)
        if 'sections' in field.metadata:
            out.update({name: to_mapping(held) for name, held in value})
        elif spec is None:
            out[field.name] = to_mapping(value)
        elif spec.keyed:
            out[field.name] = {key: list(values) for key, values in value}
        else:
            out[field.name] = list(value) if isinstance(value, tuple) else value
    return out


def flat_fields(cls: type, prefix: str = '') -> Iterator[tuple[str, Any, schema.Spec]]:
    """Every leaf field as (dotted name, default, spec), for declaring ROS parameters."""
    yield from _leaves(cls(), prefix)


def unflatten(flat: Mapping[str, Any]) -> dict[str, Any]:
    """Turn dotted keys (``world.arena_side``) into nested mappings."""
    nested: dict[str, Any] = {}
    for key, value in flat.items():
        node = nested
        *parents, leaf = key.split('.')
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = value
    return nested


def differences(section: Any, announced: Mapping[str, Any], prefix: str = '') -> list[str]:
    """How ``announced`` (a mapping, e.g. another node's section as JSON) differs from
    ``section`` as parameters: the mapping is built into a section first, so a key it leaves
    out counts at its default. One line per differing key (``prefix`` + name, both values);
    a mapping that is not a valid section is one line saying why.
    """
    try:
        theirs = from_mapping(type(section), announced, prefix)
    except schema.ParameterError as error:
        return [f'the announced {prefix.rstrip(".") or "section"} is not valid here: {error}']
    mine_flat, theirs_flat = leaves(section, prefix), leaves(theirs, prefix)
    return [f'{name}: announced {theirs_flat.get(name)!r}, here {value!r}'
            for name, value in mine_flat.items() if theirs_flat.get(name) != value]


def leaves(section: Any, prefix: str = '') -> dict[str, Any]:
    """Every parameter of a section (an instance) by its dotted key: its value."""
    return {name: value for name, value, _ in _leaves(section, prefix)}


def _leaves(section: Any, prefix: str) -> Iterator[tuple[str, Any, schema.Spec]]:
    """Every leaf field of an instance as (dotted name, value, spec)."""
    for field in schema.parameter_fields(section):
        spec = schema.spec_of(field)
        value = getattr(section, field.name)
        if 'sections' in field.metadata:
            for name, held in value:
                yield from _leaves(held, f'{prefix}{name}.')
        elif spec is None:
            yield from _leaves(value, f'{prefix}{field.name}.')
        else:
            yield f'{prefix}{field.name}', value, spec
