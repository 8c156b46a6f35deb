"""Mistakes in what a command reads, refused before its first step with nothing written: files
named by parameters, the YAML's shape (a key given twice), values a ROS node reads otherwise
than the embedded runner, a user's metric module that does not import or a metric that
returns no number; in every command that reads them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cases_launch import REFUSED_WITHIN
from cases_run import TINY, recorded_run
from mistake import MONA_SWARM, SWARM_SH, Mistake

#: A refusal that first builds the episode's starting state (the cue, the robots, a metrics
#: row): a Python start, the engine's compiled kernels loaded, no run.
BUILT_WITHIN = 180.0


def parameters(name: str, body: str):
    """A setup writing ``tmp/<name>.yaml``: a parameter file with ``body`` (lines, indented
    four spaces) under ``/**: ros__parameters:``."""
    def setup(tmp: Path) -> None:
        (tmp / f'{name}.yaml').write_text('/**:\n  ros__parameters:\n' + body)
    setup.__name__ = f'parameters_{name}'
    return setup


def cue_maps(tmp: Path) -> None:
    """Parameter files naming a missing cue map, a 'PNG' that is text, and a .npy map of cue
    300 (cue units are 0..255)."""
    (tmp / 'notes.png').write_text('not a picture\n')
    np.save(tmp / 'hot.npy', np.full((20, 20), 300.0))
    for name, file in (('missing', 'nowhere.png'), ('text', 'notes.png'), ('hot', 'hot.npy')):
        parameters(name, f'    world: {{cue_file: {file}}}\n')(tmp)


def metric_modules(tmp: Path) -> None:
    """tmp/plugins: a metric module with a syntax error, and one registering a metric whose
    compute returns the robots' x coordinates (an array) instead of one number."""
    (tmp / 'plugins').mkdir()
    (tmp / 'plugins' / 'typo_metric.py').write_text('from swarm_metrics.metrics import (\n')
    (tmp / 'plugins' / 'array_metric.py').write_text(
        'from swarm_metrics.metrics import Metric, register\n\n'
        "register(Metric('spread', 'm', 'the x of each robot', lambda s: s.positions[:, 0],\n"
        "                'spread (m)'))\n")


def recorded_with_modules(tmp: Path) -> None:
    recorded_run(tmp)
    metric_modules(tmp)


def run_in_new(*options: str) -> list[str]:
    return [MONA_SWARM, 'run', *TINY, *options, '--out', '{tmp}/new']


def launch(*options: str) -> list[str]:
    return [SWARM_SH, '--population', '3', '--duration', '2', *options, '--out', '{tmp}/new']


TWICE = parameters('twice', '    episode: {population: 3}\n    controller:\n      speed: 0.08\n'
                            '      alpha: 2.0\n      speed: 0.04\n')
PLUGINS = {'PYTHONPATH': '{tmp}/plugins', 'PYTHONDONTWRITEBYTECODE': '1'}  # no __pycache__
TYPO = {**PLUGINS, 'MONA_SWARM_METRICS': 'typo_metric'}
ARRAY = {**PLUGINS, 'MONA_SWARM_METRICS': 'array_metric'}
#: Nothing written anywhere in the scratch folder (the row's own files stay as they were).
NEW = {'unchanged': ('.',)}

CASES = [
    # Files named by parameters: read before the first step, by every runner.
    Mistake('run-cue-file-missing', run_in_new('--config', '{tmp}/missing.yaml'), 2,
            r"world\.cue_file = '\S*nowhere\.png': no such file", setup=cue_maps, **NEW),
    Mistake('run-cue-file-not-an-image', run_in_new('--config', '{tmp}/text.yaml'), 2,
            r"world\.cue_file = '\S*notes\.png': cannot read it: not an image", setup=cue_maps,
            **NEW),
    Mistake('study-cue-map-outside-0-255',
            [MONA_SWARM, 'study', '--quick', '--config', '{tmp}/hot.yaml', '--out', '{tmp}/new'],
            2, r"episode N\d+_v\d+_s1: world\.cue_file = '\S*hot\.npy': values must lie in "
               r'0\.\.255 \(found 300\.\.300\)', setup=cue_maps, timeout=BUILT_WITHIN, **NEW),
    Mistake('launch-cue-file-missing', launch('--config', '{tmp}/missing.yaml'), 2,
            r"bad parameter: world\.cue_file = '\S*nowhere\.png': no such file",
            setup=cue_maps, timeout=BUILT_WITHIN, **NEW),
    # A key twice in one mapping: YAML keeps the last without a word.
    Mistake('run-yaml-key-twice', run_in_new('--config', '{tmp}/twice.yaml'), 2,
            r'twice\.yaml line 7: controller\.speed is given twice in one mapping \(first on '
            r'line 5\)', setup=TWICE, **NEW),
    Mistake('launch-yaml-key-twice', launch('--config', '{tmp}/twice.yaml'), 2,
            r'twice\.yaml line 7: controller\.speed is given twice', setup=TWICE,
            timeout=REFUSED_WITHIN, **NEW),
    Mistake('study-claims-key-twice',
            [MONA_SWARM, 'study', '--quick', '--claims', '{tmp}/claims.yaml', '--out',
             '{tmp}/new'], 2, r'claims\.yaml line 4: claims\[0\]\.id is given twice',
            setup=lambda tmp: (tmp / 'claims.yaml').write_text(
                'claims:\n  - id: mine\n    where: here\n    id: yours\n'), **NEW),
    Mistake('calibrate-design-key-twice',
            [MONA_SWARM, 'calibrate', '{tmp}/search.yaml', '--out', '{tmp}/new'], 2,
            r'search\.yaml line 3: calibrate\.trials is given twice',
            setup=lambda tmp: (tmp / 'search.yaml').write_text(
                'calibrate:\n  trials: 8\n  trials: 16\n'), **NEW),
    Mistake('evolve-design-key-twice',
            [MONA_SWARM, 'evolve', '{tmp}/evolve.yaml', '--out', '{tmp}/new'], 2,
            r'evolve\.yaml line 4: evolve\.genomes is given twice in one mapping \(first on '
            r'line 2\)',
            setup=lambda tmp: (tmp / 'evolve.yaml').write_text(
                'evolve:\n  genomes: 8\n  seed: 2\n  genomes: 16\n'), **NEW),
    # What a ROS node would read otherwise: refused by the launcher before a node starts.
    Mistake('launch-list-of-integers-and-floats',
            launch('--config', '{tmp}/mixed.yaml'), 2,
            r'mixed\.yaml line 3: study\.speeds = \[0\.04, 1\] mixes float and integer items.*'
            r'every node would stop at start.*\[0\.04, 1\.0\]',
            setup=parameters('mixed', '    study: {speeds: [0.04, 1]}\n'),
            timeout=REFUSED_WITHIN, **NEW),
    Mistake('launch-obstacle-kind-in-its-list', launch('--config', '{tmp}/box.yaml'), 2,
            r'box\.yaml line 4: world\.obstacles\.box = \[rect, 1\.0, 1\.0, 1\.2, 1\.2\] mixes '
            r'string and float items',
            setup=parameters('box', '    world:\n      obstacles: {box: [rect, 1.0, 1.0, 1.2, '
                                    '1.2]}\n'), timeout=REFUSED_WITHIN, **NEW),
    Mistake('launch-number-ros-reads-as-text', launch('--config', '{tmp}/digits.yaml'), 2,
            r"digits\.yaml line 3: episode\.seed = 1_000 is the integer 1000 here but the "
            r"string '1_000' to a ROS node.*write 1000",
            setup=parameters('digits', '    episode: {seed: 1_000}\n'),
            timeout=REFUSED_WITHIN, **NEW),
    Mistake('launch-empty-mapping', launch('--config', '{tmp}/empty.yaml'), 2,
            r'empty\.yaml line 4: world\.sources is an empty mapping.*leave the key out',
            setup=parameters('empty', '    world:\n      sources: {}\n'),
            timeout=REFUSED_WITHIN, **NEW),
    Mistake('launch-override-mixing-types', launch('-p', 'study.speeds:=[0.04, 1]'), 2,
            r'-p study\.speeds:=\[0\.04, 1\]: study\.speeds = \[0\.04, 1\] mixes float and '
            r'integer', timeout=REFUSED_WITHIN, **NEW),
    # A user's metric module: one that does not import, a metric that returns an array.
    Mistake('run-metric-module-does-not-import', run_in_new(), 2,
            r"MONA_SWARM_METRICS: cannot import 'typo_metric': SyntaxError: "
            r'.*typo_metric\.py, line 1\); fix it', setup=metric_modules, env=TYPO, **NEW),
    Mistake('launch-metric-module-missing', launch(), 2,
            r"MONA_SWARM_METRICS: cannot import 'no_such_metrics': "
            r"ModuleNotFoundError.*put its folder on PYTHONPATH",
            env={'MONA_SWARM_METRICS': 'no_such_metrics'}, timeout=REFUSED_WITHIN, **NEW),
    Mistake('study-metric-returns-an-array',
            [MONA_SWARM, 'study', '--quick', '--out', '{tmp}/new'], 2,
            r"metric 'spread' returned an array of shape \(\d+,\), not one number",
            setup=metric_modules, env=ARRAY, timeout=BUILT_WITHIN, **NEW),
]
