"""Mistakes with ``mona-swarm study``: designs that cannot run, a folder of another design,
an analysis too small for an ANOVA."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any

from mistake import MONA_SWARM, Mistake

#: A tiny design: one population, one speed, one seed of 2 s.
TINY: dict[str, Any] = {'populations': [3], 'speeds': [0.08], 'seeds': [1], 'duration': 2.0,
                        'snapshot_times': [0.0, 2.0]}


def design(name: str, **study: Any):
    """A setup that writes ``tmp/<name>.yaml``: the shipped parameters with TINY changed by
    ``study``."""
    def setup(tmp: Path) -> None:
        from swarm_supervisor.config import load_config, write_ros_yaml
        write_ros_yaml(load_config().replace(study={**TINY, **study}), tmp / f'{name}.yaml')
    setup.__name__ = f'design_{name}'
    return setup


def earlier_study(tmp: Path) -> None:
    """A finished tiny study in tmp/earlier, and another design beside it."""
    design('tiny')(tmp)
    design('other', seeds=[1, 2])(tmp)
    subprocess.run([MONA_SWARM, 'study', '--config', str(tmp / 'tiny.yaml'), '--out',
                    str(tmp / 'earlier'), '--jobs', '1'], check=True, capture_output=True)


def one_episode(tmp: Path) -> None:
    """One episode folder (an embedded run) in tmp/episode."""
    subprocess.run([MONA_SWARM, 'run', '--population', '3', '--duration', '4', '--out',
                    str(tmp / 'episode')], check=True, capture_output=True)
    assert json.loads((tmp / 'episode' / 'episode.json').read_text())


def study_command(name: str) -> list[str]:
    """``mona-swarm study`` of ``tmp/<name>.yaml`` into tmp/new."""
    return [MONA_SWARM, 'study', '--config', f'{{tmp}}/{name}.yaml', '--out', '{tmp}/new']


CASES = [
    Mistake('study-population-too-large', study_command('big'), 2,
            r'study\.populations: episode N2000_v8_s1: population 2000 does not fit',
            setup=design('big', populations=[10, 2000]), unchanged=('new',)),
    Mistake('study-population-zero', study_command('zero'), 2,
            r'study\.populations lists 0: an episode needs at least one robot',
            setup=design('zero', populations=[0, 3]), unchanged=('new',)),
    Mistake('study-duplicate-seeds', study_command('twice'), 2,
            r'study\.seeds lists 1 more than once',
            setup=design('twice', seeds=[1, 2, 1]), unchanged=('new',)),
    Mistake('study-over-another-design',
            [MONA_SWARM, 'study', '--config', '{tmp}/other.yaml', '--out', '{tmp}/earlier'], 2,
            r'--out \S*earlier holds a study of another design: study\.seeds = \[1\] there, '
            r'\[1, 2\] here; .*--overwrite',
            setup=earlier_study, unchanged=('earlier',)),
    Mistake('study-over-a-run',
            [MONA_SWARM, 'study', '--config', '{tmp}/tiny.yaml', '--out', '{tmp}/episode'], 2,
            r'--out \S*episode holds an episode .*not a study.*--overwrite',
            setup=lambda tmp: (design('tiny')(tmp), one_episode(tmp)),
            unchanged=('episode',)),
    # Exit 0 and a report that says why there is no ANOVA (cat shows report.md).
    Mistake('study-from-one-episode',
            ['sh', '-c', f'{MONA_SWARM} study --from-episodes {{tmp}}/episode --out {{tmp}}/one'
             ' && cat {tmp}/one/report.md'], 0,
            r'\*\*Not fitted\*\*: \d+ observations leave no residual degrees of freedom',
            setup=one_episode),
]
