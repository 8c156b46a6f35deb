"""Benchmark: how fast the learning environments step (agent-steps per second).

The PettingZoo ParallelEnv (one episode) and the Gymnasium VectorEnv (K episodes on the
batched engine), N Monas each, random actions, one core; beside them the embedded runner's
BEECLUST episode of the same size for reference (its controller inside the loop). A
benchmark, not a test: the numbers depend on the machine and its load.

    .venv/bin/python bench/bench_envs.py [--population 30] [--envs 1 16 64] [--steps 500]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from swarm_supervisor.config import load_config
from swarm_supervisor.engine.runner import run_batch
from swarm_supervisor.envs import MonaSwarmParallelEnv, MonaSwarmVectorEnv


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--population', type=int, default=30)
    parser.add_argument('--envs', type=int, nargs='+', default=[1, 16, 64])
    parser.add_argument('--steps', type=int, default=500, help='env steps (32 ms each)')
    args = parser.parse_args()
    n = args.population
    config = load_config().replace(episode={'population': n, 'duration': 1e4})
    rng = np.random.default_rng(0)
    print(f'N = {n} Monas per episode, {args.steps} steps of 32 ms, random actions')
    env = MonaSwarmParallelEnv(config)
    env.reset(seed=1)
    actions = [{agent: rng.uniform([-10, -10, 0], [10, 10, 1]) for agent in env.agents}
               for _ in range(args.steps)]
    started = time.perf_counter()
    for step in actions:
        env.step(step)
    wall = time.perf_counter() - started
    print(f'{"ParallelEnv":>22}: {args.steps / wall:9.0f} env-steps/s '
          f'{args.steps * n / wall:10.0f} agent-steps/s')
    for k in args.envs:
        vector = MonaSwarmVectorEnv(k, config)
        vector.reset(seed=1)
        batch = rng.uniform([-10, -10, 0], [10, 10, 1], size=(k, n, 3))
        started = time.perf_counter()
        for _ in range(args.steps):
            vector.step(batch)
        wall = time.perf_counter() - started
        print(f'{f"VectorEnv K = {k}":>22}: {args.steps * k / wall:9.0f} env-steps/s '
              f'{args.steps * k * n / wall:10.0f} agent-steps/s')
    for k in args.envs:
        configs = [config.replace(episode={'duration': args.steps * 0.032, 'seed': s + 1})
                   for s in range(k)]
        started = time.perf_counter()
        run_batch(configs)
        wall = time.perf_counter() - started
        print(f'{f"BEECLUST run_batch K = {k}":>22}: {args.steps * k / wall:9.0f} episode-steps/s'
              f' {args.steps * k * n / wall:10.0f} robot-steps/s (metrics included)')


if __name__ == '__main__':
    main()
