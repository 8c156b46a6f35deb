"""Will a ROS node read the parameter file as the embedded runner does? Checked before the
launcher starts a node.

The embedded runner reads the parameter file with PyYAML; each node gets it from rcl's own
parser (rcl_yaml_param_parser), which is stricter and reads some values otherwise:

* one parameter holds one type, so a list mixing integers and floats (``[0.04, 1]``) or
  strings and numbers stops every node at start;
* a plain value is true/false (also y, yes, on, n, no, off in their cases), else a whole
  number as C's ``strtol`` reads it, else a real number as ``strtod`` reads it, else a string:
  ``1_000`` and ``1:30`` are numbers to PyYAML and strings to rcl, ``1e3``, ``inf`` and ``08``
  the reverse, ``y`` is a string to PyYAML and true to rcl, ``~`` is nothing to PyYAML and
  the string '~' to rcl;
* a key with no value, an alias (``*name``), a list of lists and an empty list or mapping
  are refused or read as no value.

:func:`check_ros_file` and :func:`check_ros_override` refuse each of these naming the file,
the line, the key and the fix; tests/ros/test_ros_yaml.py holds them to what rcl does. The
numbers are read by this C library's ``strtol`` and ``strtod``, as rcl reads them.
"""

from __future__ import annotations

import ctypes
import math
from pathlib import Path
from typing import Any, cast

import yaml

from mona_controller.schema import ParameterError
from swarm_supervisor.yaml_text import dotted

#: Plain words rcl reads as booleans (rcl_yaml_param_parser, parse.c get_value).
TRUE_WORDS = frozenset({'Y', 'y', 'yes', 'Yes', 'YES', 'true', 'True', 'TRUE', 'on', 'On',
                        'ON'})
FALSE_WORDS = frozenset({'N', 'n', 'no', 'No', 'NO', 'false', 'False', 'FALSE', 'off', 'Off',
                         'OFF'})
#: The spellings of infinity and NaN rcl takes in YAML's form.
SPECIAL_REALS = {f'{sign}.{word}': -math.inf if sign == '-' else math.inf
                 for sign in ('', '+', '-') for word in ('inf', 'Inf', 'INF')} | dict.fromkeys(
                     ('.nan', '.NaN', '.NAN'), math.nan)
QUOTED = ("'", '"')

_LIBC = ctypes.CDLL(None, use_errno=True)
_LIBC.strtol.restype = ctypes.c_long
_LIBC.strtol.argtypes = (ctypes.c_char_p, ctypes.POINTER(ctypes.c_char_p), ctypes.c_int)
_LIBC.strtod.restype = ctypes.c_double
_LIBC.strtod.argtypes = (ctypes.c_char_p, ctypes.POINTER(ctypes.c_char_p))


def _whole(text: str, parse: Any, *base: int) -> Any:
    """``parse(text)`` (strtol or strtod) if it reads all of a non-empty ``text`` without a
    range error, as rcl demands; else None."""
    data = text.encode()
    if not data or b'\0' in data:
        return None
    buffer = ctypes.create_string_buffer(data)
    end = ctypes.c_char_p()
    ctypes.set_errno(0)
    value = parse(buffer, ctypes.byref(end), *base)
    if ctypes.get_errno():
        return None
    used = cast(int, ctypes.cast(end, ctypes.c_void_p).value) - ctypes.addressof(buffer)
    return value if used == len(data) else None


def rcl_scalar(text: str, quoted: bool) -> bool | int | float | str:
    """The value rcl gives a scalar: a quoted one is a string; a plain one a boolean word,
    else ``strtol(text, base 0)``, else ``strtod``, else a string."""
    if quoted:
        return text
    if text in TRUE_WORDS or text in FALSE_WORDS:
        return text in TRUE_WORDS
    whole = _whole(text, _LIBC.strtol, 0)
    if whole is not None:
        return int(whole)
    if text in SPECIAL_REALS:
        return SPECIAL_REALS[text]
    real = _whole(text, _LIBC.strtod)
    return float(real) if real is not None else text


def _kind(value: Any) -> str:
    """A value's kind in words."""
    if value is None:
        return 'no value'
    if isinstance(value, bool):
        return f'the boolean {str(value).lower()}'
    if isinstance(value, int):
        return f'the integer {value}'
    if isinstance(value, float):
        return f'the float {value!r}'
    if isinstance(value, str):
        return f'the string {value!r}'
    return f'a {type(value).__name__} ({value})'


def _plain_form(value: Any) -> str:
    """How to write ``value`` so that rcl reads it as PyYAML does."""
    if value is None:
        return "give a value, or leave the key out (quote '~' for that string)"
    if isinstance(value, bool):
        return f'write {str(value).lower()}'
    if isinstance(value, (int, float)):
        return f'write {value!r}'
    if isinstance(value, str):
        return f"quote it: '{value}'"
    return f"quote it if a string is meant: '{value}'"


def _same(ours: Any, theirs: Any) -> bool:
    if type(ours) is not type(theirs):
        return False
    if isinstance(ours, float) and math.isnan(ours):
        return math.isnan(theirs)
    return bool(ours == theirs)


class _Reader:
    """Walks a parsed document as rcl would read it, refusing the first difference."""

    def __init__(self, source: str, lines: bool = True) -> None:
        self.source = source
        self.lines = lines  # name the line (of a file; not of a -p value)
        self.loader = yaml.SafeLoader('')

    def fail(self, node: yaml.Node, message: str) -> None:
        where = f' line {node.start_mark.line + 1}' if self.lines else ''
        raise ParameterError(f'{self.source}{where}: {message}')

    def value(self, node: yaml.Node, path: tuple[str, ...]) -> None:
        key = dotted(path)
        if isinstance(node, yaml.MappingNode):
            if not node.value:
                self.fail(node, f'{key} is an empty mapping, which a ROS node reads as no '
                                'value and refuses: leave the key out')
            for key_node, value_node in node.value:
                self.value(value_node, (*path, str(key_node.value)))
        elif isinstance(node, yaml.SequenceNode):
            self.sequence(node, key)
        else:
            self.scalar(node, key)

    def scalar(self, node: yaml.ScalarNode, key: str) -> Any:
        ours = self.loader.construct_object(node)
        if node.style not in QUOTED and node.value == '':
            self.fail(node, f'{key} has no value, which stops every ROS node at start: give '
                            'one, or leave the key out')
        theirs = rcl_scalar(node.value, node.style in QUOTED)
        if not _same(ours, theirs):
            self.fail(node, f'{key} = {node.value} is {_kind(ours)} here but {_kind(theirs)} '
                            f'to a ROS node, whose parser reads only plain forms: '
                            f'{_plain_form(ours)}')
        return theirs

    def sequence(self, node: yaml.SequenceNode, key: str) -> None:
        if not node.value:
            self.fail(node, f'{key} = [] is an empty list, which a ROS node reads as no value '
                            'and refuses: leave the key out, or give its items')
        items = []
        for item in node.value:
            if not isinstance(item, yaml.ScalarNode):
                self.fail(item, f'{key}: a list of lists or mappings cannot be a ROS '
                                'parameter: give one flat list')
            items.append((item, self.scalar(item, key)))
        first = _type_name(items[0][1])
        for item, value in items[1:]:
            if _type_name(value) != first:
                shown = ', '.join(i.value for i in node.value)
                fix = ('write every number with a decimal point (e.g. '
                       f'[{", ".join(_as_float(i.value) for i in node.value)}])'
                       if {first, _type_name(value)} == {'integer', 'float'} else
                       'give every item the same type (world.obstacles: the numbers alone)')
                self.fail(item, f'{key} = [{shown}] mixes {first} and {_type_name(value)} '
                                'items, but a ROS parameter list holds one type, so every '
                                f'node would stop at start: {fix}')


def _type_name(value: Any) -> str:
    return {bool: 'boolean', int: 'integer', float: 'float'}.get(type(value), 'string')


def _as_float(text: str) -> str:
    """A plain integer item written as a float (others unchanged)."""
    value = rcl_scalar(text, False)
    return f'{value:.1f}' if isinstance(value, int) and not isinstance(value, bool) else text


def _refuse_aliases(text: str, source: str) -> None:
    """rcl refuses every alias (``*name``); PyYAML resolves them."""
    for event in yaml.parse(text, Loader=yaml.SafeLoader):
        if isinstance(event, yaml.AliasEvent):
            raise ParameterError(f'{source} line {event.start_mark.line + 1}: the alias '
                                 f'*{event.anchor} is not read by ROS nodes: write the value '
                                 'out')


def check_ros_file(path: str | Path) -> None:
    """Refuse a parameter file that a ROS node would read otherwise than the embedded runner
    (or not at all). The file is read already (:func:`~swarm_supervisor.config.load_config`),
    so it exists and is valid YAML.

    Raises:
        ParameterError: naming the file, the line, the key and the fix.
    """
    text = Path(path).read_text()
    _refuse_aliases(text, str(path))
    root = yaml.compose(text, Loader=yaml.SafeLoader)
    if root is not None:
        _Reader(str(path)).value(root, ())


def check_ros_override(text: str) -> None:
    """Refuse a ``-p NAME:=VALUE`` whose value a ROS node would read otherwise than the
    launcher's checks do.

    Raises:
        ParameterError: naming the override and the fix.
    """
    name, _, value = text.partition(':=')
    source = f'-p {text}'
    try:
        _refuse_aliases(value, source)
        node = yaml.compose(value, Loader=yaml.SafeLoader)
    except yaml.YAMLError as error:
        raise ParameterError(f'{source}: the value is not YAML ({error})') from None
    if node is None:
        raise ParameterError(f'{source}: {name} has no value: give one after :=')
    if isinstance(node, yaml.MappingNode):
        raise ParameterError(f'{source}: a mapping cannot be one parameter: give each key as '
                             f'its own -p {name}.KEY:=VALUE')
    _Reader(source, lines=False).value(node, (name,))
