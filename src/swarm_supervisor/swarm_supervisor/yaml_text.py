"""YAML as every command reads it: one document, and no key twice in one mapping.

PyYAML, like most YAML readers, keeps the last of two equal keys of a mapping without a word,
so a parameter given twice in one section silently takes the later value (a copy-pasted
block, an edit below an old line). Every file a command reads (parameter files, claims,
calibration and evolution designs) goes through :func:`parse_yaml`, which refuses such a
file naming the key, both lines and the fix, and words a syntax error in one line.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from mona_controller.schema import ParameterError

#: The tag of a YAML merge key (``<<: *defaults``), which may repeat by design.
MERGE_TAG = 'tag:yaml.org,2002:merge'
#: The level of a ROS 2 parameter file that holds the parameters.
ROS_PARAMETERS = 'ros__parameters'


def parse_yaml(text: str, source: str, error: type[ParameterError] = ParameterError) -> Any:
    """The document of ``text`` (None for an empty one).

    Raises:
        ``error``: starting with ``source``: not YAML (the line and the problem), more than
            one document, or a key given twice in one mapping (its dotted path and lines).
    """
    loader = yaml.SafeLoader(text)
    try:
        root = loader.get_single_node()
        if root is None:
            return None
        repeated = _repeated_key(loader, root, (), set())
        if repeated is not None:
            key, first, again = repeated
            raise error(f'{source} line {again}: {key} is given twice in one mapping (first '
                        f'on line {first}); YAML would keep only the last: delete one')
        return loader.construct_document(root)
    except yaml.MarkedYAMLError as problem:
        mark = problem.problem_mark or problem.context_mark
        where = f' line {mark.line + 1}' if mark is not None else ''
        what = problem.problem or problem.context or 'unreadable'
        raise error(f'{source}{where}: not valid YAML: {what}') from None
    except yaml.YAMLError as problem:
        raise error(f'{source}: not valid YAML: {problem}') from None
    finally:
        loader.dispose()


def read_yaml(path: str | Path, error: type[ParameterError] = ParameterError) -> Any:
    """The document of the file ``path`` (:func:`parse_yaml`, the path as its source).

    Raises:
        ``error``: the file cannot be read, or :func:`parse_yaml` refuses it.
    """
    try:
        text = Path(path).read_text()
    except OSError as problem:
        raise error(f'cannot read {path}: {problem.strerror}') from None
    except UnicodeDecodeError:
        raise error(f'cannot read {path}: it is not a text file (UTF-8)') from None
    return parse_yaml(text, str(path), error)


def _repeated_key(loader: yaml.SafeLoader, node: yaml.Node, path: tuple[str, ...],
                  visited: set[int]) -> tuple[str, int, int] | None:
    """The first key given twice in a mapping under ``node``: (dotted key, first line,
    second line), or None. Keys compare as PyYAML builds them (``on`` and ``yes`` are both
    true), so exactly the keys it would merge are found. ``visited``: the nodes seen (an
    alias repeats a node)."""
    if id(node) in visited:
        return None
    visited.add(id(node))
    if isinstance(node, yaml.SequenceNode):
        for index, item in enumerate(node.value):
            found = _repeated_key(loader, item, (*path, f'[{index}]'), visited)
            if found is not None:
                return found
    if not isinstance(node, yaml.MappingNode):
        return None
    seen: dict[Any, int] = {}
    for key_node, value_node in node.value:
        if key_node.tag == MERGE_TAG:
            continue
        key = loader.construct_object(key_node, deep=True) if isinstance(
            key_node, yaml.ScalarNode) else id(key_node)
        text = str(key_node.value) if isinstance(key_node, yaml.ScalarNode) else str(key)
        name = dotted((*path, text))
        line = key_node.start_mark.line + 1
        try:
            if key in seen:
                return name, seen[key], line
            seen[key] = line
        except TypeError:  # an unhashable key: PyYAML refuses it when it builds the mapping
            pass
        found = _repeated_key(loader, value_node, (*path, text), visited)
        if found is not None:
            return found
    return None


def dotted(path: tuple[str, ...]) -> str:
    """A key's path as the docs name it: dotted, list indexes in brackets, and a parameter
    file's ``/**: ros__parameters:`` levels left out (``episode.population``)."""
    if ROS_PARAMETERS in path:
        path = path[path.index(ROS_PARAMETERS) + 1:] or path
    return '.'.join(path).replace('.[', '[')
