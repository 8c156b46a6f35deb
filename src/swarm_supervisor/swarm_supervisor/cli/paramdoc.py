"""Render docs/parameters.md from the schema, so the parameter reference cannot drift.

    .venv/bin/python -m swarm_supervisor.cli.paramdoc > docs/parameters.md
"""

from __future__ import annotations

import importlib
from typing import Any, cast

from mona_controller.keys import moved_keys, renamed_keys
from mona_controller.schema import Spec, parameter_fields, spec_of
from swarm_supervisor.config import FILE_RELATIVE, SwarmConfig

#: The parameters that name a file.
FILE_KEYS = set(FILE_RELATIVE)


#: Text parameters whose values come from a registry: key -> where its names are listed.
REGISTRIES = {'controller.kind': ('mona_controller.controllers', 'CONTROLLERS')}


def _type(default, spec) -> str:
    """A parameter's type as the page names it."""
    if spec.keyed:
        return 'mapping'
    if isinstance(default, tuple):
        return f'list of {_type(default[0] if default else 0.0, spec)}s'
    if spec.choices is not None:
        return 'choice'
    return {bool: 'boolean', int: 'integer', float: 'number', str: 'text'}[type(default)]


def _allowed(key: str, default, spec) -> str:
    """What a parameter may be: its choices, its range (without the unit, which has its own
    column), a registry's names, or what a text or a mapping holds."""
    if spec.keyed:
        return 'names -> non-empty lists (see meaning)'
    if spec.choices is not None:
        return ', '.join(f'`{choice}`' for choice in spec.choices)
    element = default[0] if isinstance(default, tuple) and default else default
    if isinstance(element, bool):
        return '`true`, `false`'
    if key in REGISTRIES:
        module, name = REGISTRIES[key]
        names = getattr(importlib.import_module(module), name)
        return ', '.join(f'`{kind}`' for kind in names) + ', or a registered kind'
    if isinstance(element, str):
        return 'a path, or empty' if key in FILE_KEYS else 'any text'
    if spec.low is None and spec.high is None:
        return 'any number'
    return spec.describe_range().replace(f' {spec.unit}', '') if spec.unit else \
        spec.describe_range()


def _shown(default, spec) -> str:
    """A default as the page shows it."""
    if spec.keyed:
        return '{}' if not default else str(dict(default))
    if isinstance(default, tuple):
        return ', '.join(f'{v:g}' if isinstance(v, float) else str(v) for v in default)
    if isinstance(default, bool):
        return str(default).lower()  # as the YAML writes it
    if default == '':
        return "''"
    return f'{default:g}' if isinstance(default, float) else str(default)


def _table(name: str, instance: Any, level: str) -> list[str]:
    """The table of one section, then one of each of its named sections (a controller
    kind's, one level down)."""
    lines = [f'{level} `{name}`', '', ' '.join((type(instance).__doc__ or '').split()), '',
             '| key | type | default | unit | allowed | meaning |', '|---|---|---|---|---|---|']
    named = []
    for field in parameter_fields(instance):
        if 'sections' in field.metadata:
            named += getattr(instance, field.name)
            continue
        spec = cast(Spec, spec_of(field))  # a parameter: sections are above
        default = getattr(instance, field.name)
        key = f'{name}.{field.name}'
        lines.append(f'| `{key}` | {_type(default, spec)} | {_shown(default, spec)} | '
                     f'{spec.unit} | {_allowed(key, default, spec)} | {spec.doc} |')
    lines.append('')
    for kind, section in named:
        lines += _table(f'{name}.{kind}', section, level + '#')
    return lines


def render() -> str:
    """The parameter reference as Markdown: one table per section."""
    lines = ['# Parameters', '',
             'Generated from the schema by `python -m swarm_supervisor.cli.paramdoc`; a test',
             'checks that this page matches the code. Every key lives in',
             '`ros_ws/config/mona_swarm.yaml` under `/**: ros__parameters:`; the nodes take the',
             'same keys as ROS parameters (dotted, e.g. `controller.beeclust.alpha`). Ranges are',
             'inclusive; a value outside its range, of the wrong type, or an unknown key stops',
             'the run at start-up with the key named. A number may be given as a whole number',
             'where the type is `number`; a list holds items of one type (write `[0.04, 1.0]`,',
             'not `[0.04, 1]`: ROS refuses a list that mixes integers and floats).', '']
    config = SwarmConfig()
    for section in parameter_fields(SwarmConfig):
        lines += _table(section.name, getattr(config, section.name), '##')
    renamed = {**moved_keys(SwarmConfig), **renamed_keys(SwarmConfig)}
    if renamed:
        lines += ['## Renamed keys', '',
                  'These keys still work, for one release, with a warning that names the new key:',
                  '', '| old key | new key |', '|---|---|']
        lines += [f'| `{old}` | `{new}` |' for old, new in renamed.items()]
        lines.append('')
    return '\n'.join(lines)


if __name__ == '__main__':
    print(render(), end='')
