"""Typed parameters with units and ranges: one schema for the embedded runner and the nodes.

A parameter section is a frozen dataclass whose fields are made with :func:`param`. Building
one validates every field (type and range) and names the offending key in the error, so a bad
value fails at start-up in either runner. :mod:`mona_controller.mappings` builds a section
from a (nested) mapping, rejecting unknown keys, and lists its fields as dotted ROS parameter
names for the nodes to declare; :mod:`mona_controller.keys` finds one by its dotted key.

A section holds other sections as fields (``SwarmConfig.world``), or as a :func:`sections`
field whose names are known only when it is built (one per registered controller kind:
``controller.beeclust.alpha``). A section may list keys it renamed in a ``RENAMED`` class
attribute (old name -> new dotted path below it), and a key may move to another section
(``MOVED``, ``FORMERLY``): the old key still works, with a :class:`DeprecatedKeyWarning`
naming the new one (:mod:`mona_controller.keys`).
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import warnings
from collections.abc import Callable, Mapping
from typing import Any

SCALAR_TYPES = (bool, int, float, str)


class ParameterError(ValueError):
    """A parameter is unknown, of the wrong type, or outside its allowed range."""


class DeprecatedKeyWarning(DeprecationWarning):
    """A parameter given under a key that moved: it still works, for one release."""


# Shown by default (a plain DeprecationWarning is hidden outside __main__): whoever still
# writes the old key must learn the new one before it stops working.
warnings.simplefilter('default', DeprecatedKeyWarning)


@dataclasses.dataclass(frozen=True)
class Spec:
    """What a parameter means: its unit, description and allowed values."""

    unit: str
    doc: str
    low: float | None = None
    high: float | None = None
    choices: tuple[str, ...] | None = None
    #: A mapping of names to non-empty lists of scalars (e.g. the study's factors), stored as
    #: a tuple of (name, values) pairs so the section stays frozen and hashable.
    keyed: bool = False

    def describe_range(self) -> str:
        """The allowed values, for error messages and docs."""
        if self.keyed:
            return 'a mapping of names to non-empty lists'
        if self.choices is not None:
            return 'one of ' + ', '.join(repr(c) for c in self.choices)
        low = '-inf' if self.low is None else f'{self.low:g}'
        high = 'inf' if self.high is None else f'{self.high:g}'
        unit = f' {self.unit}' if self.unit else ''
        return f'[{low}, {high}]{unit}'


def param(default: Any, *, unit: str = '', doc: str, low: float | None = None,
          high: float | None = None, choices: tuple[str, ...] | None = None,
          keyed: bool = False) -> Any:
    """A dataclass field carrying its unit, description and allowed range (inclusive).

    With ``keyed``, the field is a mapping of names to lists of scalars (default: empty);
    what the names and values mean is checked by the section that owns it.
    """
    spec = Spec(unit=unit, doc=doc, low=low, high=high, choices=choices, keyed=keyed)
    if isinstance(default, list):
        default = tuple(default)
    return dataclasses.field(default=default, metadata={'spec': spec})


def sections(lookup: Callable[[], Mapping[str, type]], *, doc: str) -> Any:
    """A field of named sections whose names are known only when the section is built:
    ``lookup()`` gives each name's section class (e.g. one per registered controller kind).
    Each sits under its own name in the mapping, beside the other fields
    (``controller.beeclust.alpha``); one not given takes its defaults. Held as a tuple of
    (name, section) pairs in ``lookup``'s order, so the section stays frozen and hashable.
    """
    return dataclasses.field(default=(), metadata={'sections': lookup, 'doc': doc})


def spec_of(field: dataclasses.Field[Any]) -> Spec | None:
    """The :class:`Spec` of a field made with :func:`param` (None for a nested section)."""
    return field.metadata.get('spec')


#: The metadata of a field that is not a parameter (e.g. the plug-ins a config loaded): the
#: schema neither builds it from a mapping, nor gives it in one, nor declares it.
NOT_A_PARAMETER = {'parameter': False}


def parameter_fields(section: Any) -> tuple[dataclasses.Field[Any], ...]:
    """The fields of a section (class or instance) that are parameters or sections."""
    return tuple(field for field in dataclasses.fields(section)
                 if field.metadata.get('parameter', True))


def named_sections(section: Any) -> dict[str, tuple[str, type]]:
    """The :func:`sections` of a section (class or instance): name -> (its field, its
    class)."""
    found = {}
    for field in parameter_fields(section):
        lookup = field.metadata.get('sections')
        if lookup is not None:
            found.update({name: (field.name, cls) for name, cls in lookup().items()})
    return found


def _filled(name: str, given: Any, classes: Mapping[str, type]) -> tuple[tuple[str, Any], ...]:
    """A :func:`sections` field's value: every name of ``classes`` in order, given or at its
    defaults."""
    given = dict(given)
    unknown = sorted(set(given) - set(classes))
    if unknown:
        raise ParameterError(f'unknown section {name}.{unknown[0]}: known {", ".join(classes)}')
    for key, value in given.items():
        if type(value) is not classes[key]:
            raise ParameterError(f'{name}.{key} must be a {classes[key].__name__}, not '
                                 f'{type(value).__name__}')
    return tuple((key, given[key] if key in given else cls()) for key, cls in classes.items())


def _coerce_keyed(name: str, value: Any) -> tuple[tuple[str, tuple[Any, ...]], ...]:
    """A mapping of names to non-empty lists of scalars, as (name, values) pairs in order."""
    if isinstance(value, tuple):  # already normalised (a copy of a built section)
        value = dict(value)
    if not isinstance(value, Mapping):
        raise ParameterError(f'{name} = {value!r}: expected a mapping of names to lists')
    pairs = []
    for key, values in value.items():
        if not isinstance(key, str) or not key:
            raise ParameterError(f'{name}: key {key!r} is not a name')
        if not isinstance(values, (list, tuple)) or not values:
            raise ParameterError(f'{name}.{key} = {values!r}: expected a non-empty list')
        if any(not isinstance(v, SCALAR_TYPES) for v in values):
            raise ParameterError(f'{name}.{key} = {values!r}: expected a list of numbers, '
                                 'strings or booleans')
        pairs.append((key, tuple(values)))
    return tuple(pairs)


def _coerce(name: str, value: Any, default: Any, spec: Spec) -> Any:
    """Check one value against its default's type and its spec; return it normalised."""
    if spec.keyed:
        return _coerce_keyed(name, value)
    kind = type(default)
    if kind is tuple:
        if not isinstance(value, (list, tuple)) or not value:
            raise ParameterError(f'{name} = {value!r}: expected a non-empty list')
        element = default[0] if default else 0.0
        return tuple(_coerce(f'{name}[{i}]', v, element, spec) for i, v in enumerate(value))
    if kind is bool:
        if not isinstance(value, bool):
            raise ParameterError(f'{name} = {value!r}: expected true or false')
        return value
    if kind is str:
        if not isinstance(value, str):
            raise ParameterError(f'{name} = {value!r}: expected a string')
        if spec.choices is not None and value not in spec.choices:
            raise ParameterError(f'{name} = {value!r} is not allowed: {spec.describe_range()}')
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParameterError(f'{name} = {value!r}: expected a number {spec.describe_range()}')
    if kind is int:
        if isinstance(value, float) and not value.is_integer():
            raise ParameterError(f'{name} = {value!r}: expected a whole number')
        value = int(value)
    else:
        value = float(value)
        if not math.isfinite(value):
            raise ParameterError(f'{name} = {value!r}: expected a finite number')
    if (spec.low is not None and value < spec.low) or (spec.high is not None
                                                       and value > spec.high):
        raise ParameterError(f'{name} = {value!r} is out of range: allowed '
                             f'{spec.describe_range()} ({spec.doc}){_unit_hint(spec)}')
    return value


#: What to say about a unit users often confuse (the CLI's --speed is in cm/s).
UNIT_HINTS = {'m/s': '; the file takes m/s (8 cm/s = 0.08)'}


def _unit_hint(spec: Spec) -> str:
    """A hint for an out-of-range value given in the wrong unit ('' if none)."""
    return UNIT_HINTS.get(spec.unit, '')


def validate(section: Any, prefix: str = '') -> None:
    """Check and normalise every field of a frozen section in place (call from __post_init__).

    Raises:
        ParameterError: naming the dotted key, the value and the allowed range.
    """
    for field in parameter_fields(section):
        lookup = field.metadata.get('sections')
        if lookup is not None:
            object.__setattr__(section, field.name, _filled(
                prefix.rstrip('.') or type(section).__name__, getattr(section, field.name),
                lookup()))
        spec = spec_of(field)
        if spec is None:
            continue
        name = prefix + field.name
        value = _coerce(name, getattr(section, field.name), field.default, spec)
        object.__setattr__(section, field.name, value)


def section_mapping(value: Any, name: str) -> Mapping[str, Any]:
    """``value``, a section of a parameter mapping: a mapping, else refused.

    Raises:
        ParameterError: naming the section ``name``.
    """
    if not isinstance(value, Mapping):
        raise ParameterError(f'{name} must be a section (a mapping)')
    return value


#: Names that moved out of this module, to where they live now: still found here, with a
#: DeprecationWarning, for one release.
MOVED = {**dict.fromkeys(('differences', 'flat_fields', 'from_mapping', 'leaves', 'merged',
                          'to_mapping', 'unflatten'), 'mona_controller.mappings'),
         **dict.fromkeys(('moved_key', 'moved_keys', 'relocate'), 'mona_controller.keys')}


def __getattr__(name: str) -> Any:
    """A name of :data:`MOVED`, from where it lives now (with a DeprecationWarning)."""
    module = MOVED.get(name)
    if module is None:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    warnings.warn(f'{__name__}.{name} moved to {module}.{name}', DeprecationWarning,
                  stacklevel=2)
    return getattr(importlib.import_module(module), name)
