"""Golden digests: the numbers of a few short episodes, pinned.

Every other exactness test compares two implementations that exist today (a batch against a
lone episode, a kernel against its reference); these compare today's outputs with the ones
recorded in ``digests.json``. A change that moves any of them moves a digest, and the commit
that rewrites ``digests.json`` must say why the numbers moved.

Each case runs through the real runner and the real writer (``write_episode``) and pins the
SHA-256 of ``metrics.csv`` and of every array of ``snapshots.npz`` (dtype, shape and bytes:
the cue maps, the poses at each snapshot, the final cue and poses, the initial poses).
The digests depend on the libraries that compute them, so ``digests.json`` records their
versions (``requirements.txt`` pins them) and the test refuses to compare across others.

    .venv/bin/python tests/golden/golden.py           # compare, print what differs
    .venv/bin/python tests/golden/golden.py --write   # record the digests anew
"""

from __future__ import annotations

import argparse
import hashlib
import json
import platform
import sys
import tempfile
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

import numpy as np

from swarm_supervisor.config import SwarmConfig, load_config
from swarm_supervisor.engine.runner import EpisodeResult, run_batch, run_episode
from swarm_supervisor.outputs.episode_folder import write_episode

DIGESTS = Path(__file__).with_name('digests.json')
#: The libraries whose arithmetic the numbers depend on.
LIBRARIES = ('numpy', 'pymunk', 'numba', 'llvmlite')


def _default() -> list[SwarmConfig]:
    """The shipped parameter file as it is, 20 robots for 300 s."""
    return [load_config().replace(episode={'population': 20, 'seed': 3, 'duration': 300.0})]


def _leaks_noise_footprint() -> list[SwarmConfig]:
    """Two moving, leaking sources (one Gaussian) on a diffusing, evaporating cue, every
    noise, a ground footprint and literal cleaning: every optional path of the world."""
    return [load_config().replace(
        episode={'population': 15, 'seed': 5, 'duration': 200.0},
        world={'sources': {'west': [0.8, 2.0, 0.5, 255.0], 'east': [2.1, 0.9, 0.6, 200.0]},
               'source_profile': {'east': ['gaussian']},
               'source_emission': {'west': [0.5], 'east': [1.0]},
               'source_velocity': {'west': [0.002, -0.001]},
               'source_path': {'east': [0.003, 2.1, 1.9, 1.5, 1.4]},
               'diffusion': 1e-4, 'half_life': 500.0, 'cleaning': 'literal'},
        sensing={'ground_noise': 5.0, 'ir_miss': 0.1, 'wheel_noise': 0.05,
                 'ground_footprint': 0.03})]


def _mixed_batch() -> list[SwarmConfig]:
    """Four episodes stepped together: other populations, speeds, gains, wall behaviour."""
    base = load_config().replace(episode={'duration': 150.0})
    return [
        base.replace(episode={'population': 10, 'seed': 1}, controller={'speed': 0.04}),
        base.replace(episode={'population': 30, 'seed': 2},
                     controller={'beeclust': {'alpha': 3.0, 'avoid': 'random-turn'}}),
        base.replace(episode={'population': 5, 'seed': 4, 'duration': 90.0},
                     mona={'ir_range': 0.05}, sensing={'wheel_noise': 0.1}),
        base.replace(episode={'population': 50, 'seed': 6}),
    ]


#: Case name -> (the configs, stepped as one batch when there are several).
CASES: dict[str, Callable[[], list[SwarmConfig]]] = {
    'default': _default,
    'leaks_noise_footprint': _leaks_noise_footprint,
    'mixed_batch': _mixed_batch,
}


def snapshot_times(config: SwarmConfig) -> tuple[float, ...]:
    """Three snapshots: the start, the middle and the end of the episode."""
    duration = config.episode.duration
    return (0.0, duration / 2, duration)


def run_case(name: str) -> list[EpisodeResult]:
    """The episodes of case ``name`` (one alone, several as one batch)."""
    configs = CASES[name]()
    times = snapshot_times(configs[0])
    if len(configs) == 1:
        return [run_episode(configs[0], snapshot_times=times)]
    return run_batch(configs, snapshot_times=times)


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def episode_digests(result: EpisodeResult) -> dict[str, str]:
    """The digests of one episode's outputs as ``write_episode`` writes them."""
    with tempfile.TemporaryDirectory() as folder:
        out = write_episode(result, folder)
        digests = {'metrics.csv': _sha((out / 'metrics.csv').read_bytes())}
        with np.load(out / 'snapshots.npz') as arrays:
            for key in sorted(arrays.files):
                array = np.ascontiguousarray(arrays[key])
                digests[f'snapshots.npz:{key}'] = _sha(
                    f'{array.dtype.str}{array.shape}'.encode() + array.tobytes())
    return digests


def case_digests(name: str) -> list[dict[str, str]]:
    """One mapping of digests per episode of case ``name``."""
    return [episode_digests(result) for result in run_case(name)]


def library_versions() -> dict[str, str]:
    """The versions of :data:`LIBRARIES` and of Python here."""
    versions = {name: metadata.version(name) for name in LIBRARIES}
    versions['python'] = platform.python_version()
    return versions


def load() -> dict:
    """The recorded digests: ``{'libraries': ..., 'cases': {name: [episode digests]}}``."""
    return json.loads(DIGESTS.read_text())


def differences(recorded: list[dict[str, str]], now: list[dict[str, str]]) -> list[str]:
    """What differs between two cases' digests, one line per file (empty: none)."""
    if len(recorded) != len(now):
        return [f'{len(now)} episodes, {len(recorded)} recorded']
    lines = []
    for k, (old, new) in enumerate(zip(recorded, now)):
        for key in sorted(set(old) | set(new)):
            if old.get(key) != new.get(key):
                lines.append(f'episode {k}: {key}: {old.get(key)} -> {new.get(key)}')
    return lines


def main(argv: list[str] | None = None) -> int:
    """Compare the cases with digests.json (exit 1 if any differs), or record them anew."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--write', action='store_true',
                        help='record the digests anew (say why the numbers moved in the commit)')
    args = parser.parse_args(argv)
    cases = {name: case_digests(name) for name in CASES}
    if args.write:
        DIGESTS.write_text(json.dumps({'libraries': library_versions(), 'cases': cases},
                                      indent=2, sort_keys=True) + '\n')
        print(f'wrote {DIGESTS}')
        return 0
    recorded = load()
    status = 0
    for name, digests in cases.items():
        lines = differences(recorded['cases'].get(name, []), digests)
        print(f'{name}: {"unchanged" if not lines else "CHANGED"}')
        for line in lines:
            print(f'  {line}')
        status = status or int(bool(lines))
    return status


if __name__ == '__main__':
    sys.exit(main())
