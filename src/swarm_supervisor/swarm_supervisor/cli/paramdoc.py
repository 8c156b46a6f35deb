"""Render docs/parameters.md from the schema, so the parameter reference cannot drift.

    .venv/bin/python -m swarm_supervisor.cli.paramdoc > docs/parameters.md
"""

from __future__ import annotations

import dataclasses
from typing import Any

from mona_controller.keys import renamed_keys
from mona_controller.schema import spec_of
from swarm_supervisor.config import SwarmConfig


def _shown(default, spec) -> str:
    """A default as the page shows it."""
    if spec.keyed:
        return '{}' if not default else str(dict(default))
    if isinstance(default, tuple):
        return ', '.join(f'{v:g}' if isinstance(v, float) else str(v) for v in default)
    return f'{default:g}' if isinstance(default, float) else str(default)


def _table(name: str, instance: Any, level: str) -> list[str]:
    """The table of one section, then one of each of its named sections (a controller
    kind's, one level down)."""
    lines = [f'{level} `{name}`', '', ' '.join((type(instance).__doc__ or '').split()), '',
             '| key | default | unit | allowed | meaning |', '|---|---|---|---|---|']
    named = []
    for field in dataclasses.fields(instance):
        if 'sections' in field.metadata:
            named += getattr(instance, field.name)
            continue
        spec = spec_of(field)
        default = getattr(instance, field.name)
        allowed = spec.describe_range().replace(f' {spec.unit}', '') if spec.unit else \
            spec.describe_range()
        lines.append(f'| `{name}.{field.name}` | {_shown(default, spec)} | {spec.unit} | '
                     f'{allowed} | {spec.doc} |')
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
             'the run at start-up with the key named.', '']
    config = SwarmConfig()
    for section in dataclasses.fields(SwarmConfig):
        lines += _table(section.name, getattr(config, section.name), '##')
    renamed = renamed_keys(SwarmConfig)
    if renamed:
        lines += ['## Renamed keys', '',
                  'These keys still work, for one release, with a warning that names the new key:',
                  '', '| old key | new key |', '|---|---|']
        lines += [f'| `{old}` | `{new}` |' for old, new in renamed.items()]
        lines.append('')
    return '\n'.join(lines)


if __name__ == '__main__':
    print(render(), end='')
