"""Benchmark: what leaks beyond the paper cost the embedded runner at N = 50.

Runs the same N = 50 episode (one seed) with the paper's still disc and with the scenario of
ros_ws/config/designs/moving_leaks.yaml (two moving, leaking sources, evaporation, and
diffusion at the design's upper level, 1e-4 m^2/s: 5 substeps per transport tick), alternating
the two ``--rounds`` times so a change in machine load hits both alike. Prints each run's real
time factor (sim seconds per wall second, and per CPU second: steadier on a shared machine)
and the medians. Target: the scenario
above 250x, and the paper's field as fast as without the feature.

    .venv/bin/python bench/bench_leaks.py [--duration 400] [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from swarm_supervisor.config import SwarmConfig, load_config
from swarm_supervisor.engine.runner import run_episode

DESIGN = Path(__file__).resolve().parents[1] / 'ros_ws' / 'config' / 'designs' / \
    'moving_leaks.yaml'
TARGET = 250.0


def scenarios(duration: float, seed: int) -> dict[str, SwarmConfig]:
    """The paper's field and the moving-leaks scenario, N = 50 at 8 cm/s."""
    episode = {'population': 50, 'duration': duration, 'seed': seed}
    paper = SwarmConfig().replace(episode=episode)
    leaks = load_config(DESIGN).replace(episode=episode, world={'diffusion': 1e-4})
    return {'paper': paper, 'moving leaks': leaks}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--duration', type=float, default=400.0, help='sim seconds per run')
    parser.add_argument('--rounds', type=int, default=3, help='runs of each scenario')
    parser.add_argument('--seed', type=int, default=1)
    args = parser.parse_args()
    configs = scenarios(args.duration, args.seed)
    run_episode(configs['moving leaks'].replace(episode={'duration': 5.0}))  # compile kernels
    factors: dict[str, list[tuple[float, float]]] = {name: [] for name in configs}
    for k in range(args.rounds):
        for name, config in configs.items():
            cpu = time.process_time()
            result = run_episode(config)
            sim = result.steps * config.world.step_period
            factor = (result.real_time_factor, sim / (time.process_time() - cpu))
            factors[name].append(factor)
            print(f'round {k + 1}: {name:13s} {factor[0]:6.0f}x real time, {factor[1]:6.0f}x '
                  'per CPU second', flush=True)
    medians = {name: (statistics.median(f[0] for f in values),
                      statistics.median(f[1] for f in values))
               for name, values in factors.items()}
    for name, (wall, cpu) in medians.items():
        print(f'median {name:13s} {wall:6.0f}x real time, {cpu:6.0f}x per CPU second')
    leaks, paper = medians['moving leaks'], medians['paper']
    print(f'moving leaks / paper: {leaks[0] / paper[0]:.2f} (wall), {leaks[1] / paper[1]:.2f} '
          f'(CPU); target {TARGET:.0f}x: {"met" if leaks[0] >= TARGET else "missed"}')


if __name__ == '__main__':
    main()
