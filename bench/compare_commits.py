"""Benchmark: the embedded runner of another commit against this working tree, in one run.

A speed claim between two commits is only fair when both are timed on the same machine under
the same load, so this runs them alternately, round after round, each in a fresh process
(its own source tree first on PYTHONPATH, this venv's libraries), and reports the best wall
time of each side and their ratio. The other commit is checked out as a git worktree in a
temporary folder. Measured (the paper's arena, seed 1): one lone N = 50 episode and one
batch of 16 N = 50 episodes (the study's default batch), ``--duration`` sim seconds each.

    .venv/bin/python bench/compare_commits.py 23ff007 [--rounds 3] [--duration 400]

A benchmark, not a test: the numbers depend on the machine and its load; the ratio is what
to read (< 1: this tree is faster).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import site
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ('mona_controller', 'swarm_world', 'swarm_metrics', 'swarm_supervisor')

# Runs inside each side's process; imports what either layout of the engine provides.
PROBE = r"""
import json, sys, time
try:
    from swarm_supervisor.engine.runner import run_batch, run_episode
except ImportError:  # before the engine/ sub-package
    from swarm_supervisor.runner import run_batch, run_episode
from swarm_supervisor.config import load_config
duration = float(sys.argv[1])
base = load_config()
run_episode(base.replace(episode={'population': 300, 'duration': 1.0}))  # compile kernels
run_batch([base.replace(episode={'population': 5, 'duration': 1.0})] * 2)
lone = base.replace(episode={'population': 50, 'duration': duration, 'seed': 1})
started = time.perf_counter()
first = run_episode(lone)
lone_wall = time.perf_counter() - started
batch = [base.replace(episode={'population': 50, 'duration': duration, 'seed': s + 1})
         for s in range(16)]
started = time.perf_counter()
run_batch(batch)
batch_wall = time.perf_counter() - started
print(json.dumps({'lone': lone_wall, 'batch': batch_wall,
                  'final_cue': first.metrics[-1]['mean_cue']}))
"""


def side_env(tree: Path) -> dict[str, str]:
    """The environment that makes ``tree``'s packages the ones imported: its sources, then this
    venv's libraries. The probe runs with ``python -S``: the venv's editable installs are
    import hooks in .pth files that would otherwise win over PYTHONPATH."""
    paths = [str(tree / 'src' / name) for name in PACKAGES] + site.getsitepackages()
    tag = hashlib.sha256(str(tree).encode()).hexdigest()[:12]  # one numba cache per tree
    return dict(os.environ, PYTHONPATH=os.pathsep.join(paths),
                NUMBA_CACHE_DIR=str(Path(tempfile.gettempdir()) / f'numba-{tag}'))


def measure(tree: Path, duration: float) -> dict[str, float]:
    """One round of the probe in ``tree`` (a fresh process)."""
    done = subprocess.run([sys.executable, '-S', '-c', PROBE, str(duration)], cwd=tree,
                          env=side_env(tree), capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('base', help='the other commit (any git revision)')
    parser.add_argument('--rounds', type=int, default=3)
    parser.add_argument('--duration', type=float, default=400.0, help='sim s per episode')
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        other = Path(folder) / 'base'
        subprocess.run(['git', 'worktree', 'add', '--detach', str(other), args.base],
                       cwd=ROOT, check=True, capture_output=True)
        try:
            sides = {args.base: other, 'this tree': ROOT}
            best = {name: {'lone': float('inf'), 'batch': float('inf')} for name in sides}
            cues = {}
            for round_ in range(args.rounds):
                for name, tree in sides.items():
                    times = measure(tree, args.duration)
                    cues[name] = times['final_cue']
                    for key in ('lone', 'batch'):
                        best[name][key] = min(best[name][key], times[key])
                    print(f'round {round_ + 1}: {name:>10}: lone {times["lone"]:6.2f} s, '
                          f'batch of 16 {times["batch"]:6.2f} s', flush=True)
        finally:
            subprocess.run(['git', 'worktree', 'remove', '--force', str(other)], cwd=ROOT,
                           capture_output=True)
    base, this = best[args.base], best['this tree']
    print(f'best of {args.rounds}, N = 50, {args.duration:g} s episodes:')
    for key, label in (('lone', 'lone episode'), ('batch', 'batch of 16')):
        print(f'  {label:>13}: {args.base} {base[key]:6.2f} s, this tree {this[key]:6.2f} s, '
              f'ratio {this[key] / base[key]:.3f} '
              f'({args.duration / this[key] * (16 if key == "batch" else 1):.0f}x real time '
              'per episode here)')
    same = cues[args.base] == cues['this tree']
    print(f'  the lone episode ends at the same mean cue on both: {same}')


if __name__ == '__main__':
    main()
