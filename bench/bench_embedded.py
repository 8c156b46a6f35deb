"""Benchmark: real-time factor of the embedded runner, and where a step's time goes.

Runs one episode per population with the shipped parameters and prints simulated seconds per
wall second, then times each part of the step (sense: ground + IR, controller, physics +
cleaning, metrics) on an N = 50 swarm. A benchmark, not a test: the numbers depend on the
machine. Target (issue 2): at least 250x real time for N = 50 on one core.

    .venv/bin/python bench/bench_embedded.py [--duration 400] [--populations 10 30 50]
"""

from __future__ import annotations

import argparse
import time

from swarm_supervisor.config import load_config
from swarm_supervisor.episode import Episode
from swarm_supervisor.runner import run_episode


def split(config, steps: int) -> dict[str, float]:
    """Microseconds per step spent in each part of the step, for one episode's first steps."""
    episode = Episode(config, profile=True)
    for _ in range(steps):
        episode.step()
    spent = dict(episode.profile)
    clock = time.perf_counter
    t0 = clock()
    for _ in range(100):
        episode.metrics()
    per_sample = (clock() - t0) / 100
    spent['metrics (per step share)'] = per_sample * steps * config.world.step_period
    return {key: value / steps * 1e6 for key, value in spent.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--duration', type=float, default=400.0, help='sim seconds per run')
    parser.add_argument('--populations', type=int, nargs='+', default=[10, 30, 50])
    parser.add_argument('--seed', type=int, default=1)
    args = parser.parse_args()
    base = load_config()
    run_episode(base.replace(episode={'population': 2, 'duration': 1.0}))  # compile kernels
    print(f'embedded runner, {args.duration:g} s episodes, seed {args.seed}')
    factors = {}
    for population in args.populations:
        config = base.replace(episode={'population': population, 'duration': args.duration,
                                       'seed': args.seed})
        result = run_episode(config)
        factors[population] = result.real_time_factor
        print(f'  N = {population:3d}: {result.real_time_factor:7.1f}x real time '
              f'({result.wall_time / result.steps * 1e6:6.1f} us per step, '
              f'{result.wall_time:6.2f} s wall)')
    largest = max(args.populations)
    print(f'  4000 s episode at N = {largest}: about {4000 / factors[largest]:.1f} s wall; '
          f'target 250x -> {factors[largest] / 250:.2f} of target')
    config = base.replace(episode={'population': largest, 'seed': args.seed})
    parts = split(config, steps=6000)
    total = sum(parts.values())
    print(f'where a step goes at N = {largest} (us per step, instrumented):')
    for name, value in parts.items():
        print(f'  {name:26s} {value:7.1f}  ({value / total:5.1%})')
    print(f'  {"total":26s} {total:7.1f}')


if __name__ == '__main__':
    main()
