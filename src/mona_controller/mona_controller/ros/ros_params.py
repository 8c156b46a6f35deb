"""Declare a parameter section of the schema as ROS parameters, and build it back.

The schema (:mod:`mona_controller.schema`) is the one source of truth: each field becomes a
read-only ROS parameter whose descriptor carries the field's description, unit and range, so
``ros2 param describe`` shows what the YAML comments say. The values the node received
(``--params-file``, ``-p``) are then validated by building the frozen dataclass, exactly as
the embedded runner does; any problem raises :class:`~mona_controller.schema.ParameterError`
naming the parameter and its allowed range.
"""

from __future__ import annotations

import array
import math
import re
from collections.abc import Iterable
from typing import Any, TypeVar

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter

from mona_controller import plugins
from mona_controller.keys import moved_keys, renamed_keys
from mona_controller.mappings import flat_fields, from_mapping, unflatten
from mona_controller.schema import ParameterError, Spec

T = TypeVar('T')

INT64_MIN, INT64_MAX = -2**63, 2**63 - 1


def descriptor(name: str, default: Any, spec: Spec) -> ParameterDescriptor:
    """The ROS descriptor of one schema field: description with unit, range, read-only.

    Types are dynamic so that, as in the embedded runner, ``2`` is accepted for a float; the
    schema checks the type when the section is built.
    """
    unit = f' [{spec.unit}]' if spec.unit else ''
    desc = ParameterDescriptor(name=name, description=spec.doc + unit, read_only=True,
                               dynamic_typing=True,
                               additional_constraints=spec.describe_range())
    scalar = default[0] if isinstance(default, tuple) and default else default
    if spec.low is None and spec.high is None or isinstance(default, tuple):
        return desc
    if isinstance(scalar, bool):
        return desc
    if isinstance(scalar, int):
        low = INT64_MIN if spec.low is None else max(math.ceil(spec.low), INT64_MIN)
        high = INT64_MAX if spec.high is None else min(math.floor(spec.high), INT64_MAX)
        desc.integer_range = [IntegerRange(from_value=low, to_value=high, step=0)]
    elif isinstance(scalar, float):
        low = -math.inf if spec.low is None else float(spec.low)
        high = math.inf if spec.high is None else float(spec.high)
        desc.floating_point_range = [FloatingPointRange(from_value=low, to_value=high,
                                                        step=0.0)]
    return desc


def _plain(value: Any) -> Any:
    """A parameter value as the schema expects it (arrays become lists)."""
    if isinstance(value, (array.array, tuple)):
        return list(value)
    if hasattr(value, 'tolist'):  # numpy arrays from some rclpy paths
        return value.tolist()
    return value


def declare_section(node: Node, cls: type[T], prefix: str = '') -> T:
    """Declare every field of section ``cls`` under ``prefix`` and build it from the values.

    Args:
        node: the node to declare on.
        cls: a schema section (or a composition of sections such as the whole config).
        prefix: the dotted prefix of the section, e.g. ``'controller.'`` ('' for none).

    A parameter given under a key that moved into the section (``mona.ground_noise`` for
    ``sensing.ground_noise``) or that the schema renamed (``controller.alpha`` for
    ``controller.beeclust.alpha``) is taken as the new one, with a warning in the node's log;
    one that moved out of it is left to the section it joined.

    Raises:
        ParameterError: an out-of-range, mistyped or unknown value, or a key given under both
            its old and its new name, naming the parameter and its allowed range.
    """
    values, known = {}, set()
    moved = {**_moved_overrides(node, cls, prefix, known),
             **_renamed_overrides(node, cls, prefix, known)}
    for name, default, spec in flat_fields(cls, prefix):
        if spec.keyed:
            values[name[len(prefix):]] = _declare_keyed(node, name)
            known.update(f'{name}.{key}' for key in values[name[len(prefix):]])
            continue
        ros_default = moved.get(name, default)
        ros_default = list(ros_default) if isinstance(ros_default, tuple) else ros_default
        try:
            param = node.declare_parameter(name, ros_default, descriptor(name, default, spec))
        except ParameterException as error:
            # rclpy checks the range itself when the override arrives: say it the schema's way.
            found = re.search(r'Invalid parameter value \((.*)\) for parameter', str(error))
            value = found.group(1) if found else '?'
            raise ParameterError(f'{name} = {value} is out of range: allowed '
                                 f'{spec.describe_range()} ({spec.doc})') from None
        values[name[len(prefix):]] = _plain(param.value)
        known.add(name)
    check_unknown(node, [prefix] if prefix else sorted({n.split('.')[0] + '.' for n in values}),
                  known)
    return from_mapping(cls, unflatten(values), prefix)


def _moved_overrides(node: Node, cls: type, prefix: str, known: set[str]) -> dict[str, Any]:
    """The values the node was given under keys that moved into section ``cls``, by their new
    keys (warned about in the log); the keys that moved out of it are added to ``known``."""
    overrides = getattr(node, '_parameter_overrides', {})  # rclpy keeps them only privately
    given = {old: new for old, new in moved_keys(cls, prefix).items() if old in overrides}
    known.update(given)
    fields = {name for name, _, _ in flat_fields(cls, prefix)}
    into = {old: new for old, new in given.items() if new in fields}
    for old, new in into.items():
        if new in overrides:
            raise ParameterError(f'{old} and {new} are both given: give {new} only')
        node.get_logger().warning(f'{old} is deprecated: use {new}')
    return {new: _plain(overrides[old].value) for old, new in into.items()}


def _renamed_overrides(node: Node, cls: type, prefix: str, known: set[str]) -> dict[str, Any]:
    """The values given under renamed keys, by their new keys (each old key declared, added
    to ``known`` and warned about in the log)."""
    overrides = getattr(node, '_parameter_overrides', {})  # rclpy keeps them only privately
    moved = {}
    for old, new in renamed_keys(cls, prefix).items():
        if old not in overrides:
            continue
        if new in overrides:
            raise ParameterError(f'{old} and {new} are both given: give {new} only')
        param = node.declare_parameter(old, descriptor=ParameterDescriptor(
            name=old, read_only=True, dynamic_typing=True,
            description=f'deprecated: use {new}'))
        moved[new] = _plain(param.value)
        known.add(old)
        node.get_logger().warning(f'{old} is deprecated: use {new}')
    return moved


def _declare_keyed(node: Node, name: str) -> dict[str, Any]:
    """A keyed field (``study.factors``) as ROS parameters: a ROS parameter cannot hold a
    mapping, so each entry the node was given (``study.factors.mona.ir_range``) becomes a
    read-only parameter of its own; the mapping is built back from them."""
    overrides = getattr(node, '_parameter_overrides', {})  # rclpy keeps them only privately
    mapping = {}
    for full in sorted(o for o in overrides if o.startswith(name + '.')):
        param = node.declare_parameter(full, descriptor=ParameterDescriptor(
            name=full, read_only=True, dynamic_typing=True))
        mapping[full[len(name) + 1:]] = _plain(param.value)
    return mapping


def check_unknown(node: Node, prefixes: Iterable[str], known: set[str]) -> None:
    """Reject an override under ``prefixes`` that the node did not declare (a typo in YAML).

    The embedded runner rejects unknown keys; so must the nodes, or a misspelt parameter would
    silently keep its default in one runner only.
    """
    overrides = getattr(node, '_parameter_overrides', {})  # rclpy keeps them only privately
    for name in sorted(overrides):
        if any(name.startswith(p) for p in prefixes) and name not in known:
            section = next(p for p in prefixes if name.startswith(p))
            choices = ', '.join(sorted(k[len(section):] for k in known
                                       if k.startswith(section)))
            raise ParameterError(f'unknown parameter {name}; known in {section[:-1]}: '
                                 f'{choices}')



def declare_plugins(node: Node) -> tuple[plugins.Plugin, ...]:
    """Declare the ``plugins`` parameter (the run's plug-in files; the launcher hands every
    node their absolute paths, a node started by hand resolves relative ones against its
    current directory) and load them after the installed plug-ins
    (:func:`mona_controller.plugins.load`): before any section that may name what they
    register (a controller kind, an obstacle layout) is declared.

    Returns:
        The loaded plug-ins' records.

    Raises:
        ParameterError: a plug-in cannot be loaded (naming it).
    """
    param = node.declare_parameter(plugins.KEY, Parameter.Type.STRING_ARRAY, ParameterDescriptor(
        name=plugins.KEY, read_only=True,
        description='plug-in files: Python modules registering metrics, controller kinds or '
                    'obstacle layouts (docs/extending.md)'))
    paths = list(param.value or ()) if param.type_ == Parameter.Type.STRING_ARRAY else []
    return plugins.load(plugins.resolve(paths, None))
