"""Render docs/parameters.md from the schema, so the parameter reference cannot drift.

    .venv/bin/python -m swarm_supervisor.cli.paramdoc > docs/parameters.md
"""

from __future__ import annotations

import dataclasses

from mona_controller.schema import parameter_fields, spec_of
from swarm_supervisor.config import SwarmConfig


def _shown(default, spec) -> str:
    """A default as the page shows it."""
    if spec.keyed:
        return '{}' if not default else str(dict(default))
    if isinstance(default, tuple):
        return ', '.join(f'{v:g}' if isinstance(v, float) else str(v) for v in default)
    return f'{default:g}' if isinstance(default, float) else str(default)


def render() -> str:
    """The parameter reference as Markdown: one table per section."""
    lines = ['# Parameters', '',
             'Generated from the schema by `python -m swarm_supervisor.cli.paramdoc`; a test',
             'checks that this page matches the code. Every key lives in',
             '`ros_ws/config/mona_swarm.yaml` under `/**: ros__parameters:`; the nodes take the',
             'same keys as ROS parameters (dotted, e.g. `controller.alpha`). Ranges are',
             'inclusive; a value outside its range, of the wrong type, or an unknown key stops',
             'the run at start-up with the key named.', '',
             'Beside the sections, `plugins:` lists plug-in files (Python modules that register',
             'metrics, controller kinds or obstacle layouts), each path absolute or relative to',
             'the parameter file; they are loaded before the parameters are checked',
             '([extending.md](extending.md)).', '']
    config = SwarmConfig()
    for section in parameter_fields(SwarmConfig):
        instance = getattr(config, section.name)
        text = ' '.join((type(instance).__doc__ or '').split())
        formerly = sorted({old.rpartition('.')[0] for old in
                           getattr(type(instance), 'FORMERLY', {}).values()})
        if formerly:
            text += (f' These keys were {", ".join(f"`{s}.<key>`" for s in formerly)}: the old '
                     'keys still work for one release, with a warning naming the new one.')
        lines += [f'## `{section.name}`', '', text, '',
                  '| key | default | unit | allowed | meaning |', '|---|---|---|---|---|']
        for field in dataclasses.fields(instance):
            spec = spec_of(field)
            default = getattr(instance, field.name)
            shown = _shown(default, spec)
            allowed = spec.describe_range().replace(f' {spec.unit}', '') if spec.unit else \
                spec.describe_range()
            lines.append(f'| `{section.name}.{field.name}` | {shown} | {spec.unit} | '
                         f'{allowed} | {spec.doc} |')
        lines.append('')
    return '\n'.join(lines)


if __name__ == '__main__':
    print(render(), end='')
