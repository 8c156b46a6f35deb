"""Benchmark: real-time factor of the embedded runner from 50 to 10,000 Monas, and where a
step's time goes.

Populations 50, 500, 1,000, 2,000 and 10,000 (by default) run in an arena scaled to the
paper's density: the shipped 2.85 m arena holds the paper's largest swarm, N = 50, and N
robots get a square arena of side 2.85 * sqrt(N / 50) m, with the cue disc's diameter scaled
by the same factor (N = 10,000: 40.3 m, a 4,030 x 4,030 cue raster). For each N it runs one
episode with the embedded runner (``run_episode``: set-up, placement, every step and every
metrics sample, as ``mona-swarm run`` does, outputs excepted) and prints simulated seconds per
wall second and per CPU second; then the same episode again with ``Episode(profile=True)`` for
the split of a step (ground sensors, IR, controller, physics + cleaning, metrics samples).
A benchmark, not a test: the numbers depend on the machine and its load. Targets:
N = 10,000 at 1x real time or better on one core, N = 1,000 at 20x, N = 50 at least 250x.

First, the batched engine: for N = 10 and 50 in the shipped arena, batches of 1, 4,
16 and 64 episodes (seeds 1..K) stepped together by ``run_batch``, each episode's real-time
factor (K x sim seconds per wall second) and the split of a step per episode (a profiled
batch; metrics samples and bookkeeping are the rest). Target: N = 50 at 900x per episode in
batches of 16 (the study's default). The episodes run 400 s by default, as the lone ones.

    .venv/bin/python bench/bench_embedded.py [--populations 50 1000 10000] [--duration 400]
        [--batch-sizes 1 4 16 64] [--batch-populations 10 50] [--batch-duration 400]

Large swarms run shorter episodes (``--duration`` * 500 / N, at least ``--min-duration``),
so the whole benchmark takes a few minutes here.

With ``--profiles``, only the cost of the Monas' sensing chain: each profile of
``ros_ws/config/profiles/`` and the idealised model on the 3.9 mm raster of a Webots Display
(``world.cell_size`` 1/256 m), N = 50 at 8 cm/s in a batch of the study's size, each as a
ratio to the idealised model measured in the same run (alternating, best of three rounds).
"""

from __future__ import annotations

import argparse
import math
import time

from swarm_supervisor.config import SwarmConfig, load_config
from swarm_supervisor.engine.batch import Batch
from swarm_supervisor.engine.episode import PARTS, Episode
from swarm_supervisor.engine.runner import run_batch, run_episode
from swarm_supervisor.study import DEFAULT_BATCH_SIZE

#: The paper's largest swarm, which the shipped arena holds: the density every N runs at.
REFERENCE_POPULATION = 50
#: Real-time targets: the population and the factor it must reach.
TARGETS = {50: 250.0, 1000: 20.0, 10000: 1.0}


def at_paper_density(base: SwarmConfig, population: int, duration: float,
                     seed: int) -> SwarmConfig:
    """``base`` with ``population`` robots in an arena scaled to hold them at the density of
    :data:`REFERENCE_POPULATION` robots in ``base``'s arena (cue disc scaled alike)."""
    scale = math.sqrt(population / REFERENCE_POPULATION)
    return base.replace(
        episode={'population': population, 'duration': duration, 'seed': seed},
        world={'arena_side': base.world.arena_side * scale,
               'cue_diameter': base.world.cue_diameter * scale})


def split(config: SwarmConfig) -> tuple[dict[str, float], float]:
    """Microseconds per step spent in each part of the step over one whole episode, and the
    set-up (world, controllers, placement) in seconds."""
    started = time.perf_counter()
    episode = Episode(config, profile=True)
    setup = time.perf_counter() - started
    sampling = 0.0
    clock = time.perf_counter
    t0 = clock()
    episode.metrics()
    sampling += clock() - t0
    while not episode.done:
        if episode.step().sampled:
            t0 = clock()
            episode.metrics()
            sampling += clock() - t0
    spent = dict(episode.profile)
    spent['metrics samples'] = sampling
    return {key: value / episode.steps_done * 1e6 for key, value in spent.items()}, setup


#: The batched engine's target: N = 50 at this real-time factor per episode, in
#: batches of the study's default size.
BATCH_TARGET = (50, 900.0)


def batched(base: SwarmConfig, populations: list[int], sizes: list[int], duration: float,
            split_parts: bool) -> None:
    """Print each episode's real-time factor in batches of each size, and the split."""
    print(f'batched engine: K episodes of {duration:g} s (seeds 1..K) stepped together, '
          'per episode')
    names = (*PARTS, 'rest')
    print(f'{"N":>4} {"K":>4} {"wall s":>7} {"us/ep-step":>10} {"x real time":>11} '
          f'{"x (CPU)":>8}' + ('  ' + ' '.join(f'{name:>16}' for name in names)
                               if split_parts else ''))
    for population in populations:
        for size in sizes:
            configs = [base.replace(episode={'population': population, 'duration': duration,
                                             'seed': seed + 1}) for seed in range(size)]
            cpu, started = time.process_time(), time.perf_counter()
            run_batch(configs)
            wall, cpu = time.perf_counter() - started, time.process_time() - cpu
            steps = configs[0].steps() * size
            line = (f'{population:4d} {size:4d} {wall:7.2f} {wall / steps * 1e6:10.1f} '
                    f'{size * duration / wall:10.1f}x {size * duration / cpu:7.1f}x')
            if split_parts:
                batch = Batch([Episode(config) for config in configs], profile=True)
                while not batch.done:
                    batch.step()
                # The parts of the profiled run, beside the plain run's us per step: 'rest'
                # is what the parts leave of it (metrics samples, collection, regrouping).
                total = wall / steps * 1e6
                parts = {name: value / steps * 1e6 for name, value in batch.profile.items()}
                parts['rest'] = max(total - sum(parts.values()), 0.0)
                line += '  ' + ' '.join(f'{parts[name]:9.1f} ({parts[name] / total:3.0%})'
                                        for name in names)
            if (population, size) == (BATCH_TARGET[0], DEFAULT_BATCH_SIZE):
                met = size * duration / wall >= BATCH_TARGET[1]
                line += f'  target {BATCH_TARGET[1]:g}x: {"met" if met else "MISSED"}'
            print(line, flush=True)


#: The variants of --profiles: name -> how they change the base (the shipped parameter file).
FINE_RASTER = {'world': {'cell_size': 1 / 256}}


def profiles(base: SwarmConfig, duration: float, rounds: int = 3) -> None:
    """Print each profile's real-time factor per episode and its ratio to the idealised one."""
    from swarm_supervisor.analysis.profile import PROFILES_DIR
    variants = {path.stem: load_config(path) for path in sorted(PROFILES_DIR.glob('*.yaml'))}
    variants['idealised, 3.9 mm raster'] = base.replace(**FINE_RASTER)
    size = DEFAULT_BATCH_SIZE
    best = dict.fromkeys(variants, math.inf)
    for _ in range(rounds):  # alternate, so the machine's load falls on every variant alike
        for name, config in variants.items():
            configs = [config.replace(episode={'population': 50, 'duration': duration,
                                               'seed': seed + 1}) for seed in range(size)]
            started = time.perf_counter()
            run_batch(configs)
            best[name] = min(best[name], time.perf_counter() - started)
    print(f'sensing-chain profiles: N = 50, 8 cm/s, {size} episodes of {duration:g} s in a '
          f'batch, best of {rounds}')
    reference = best['idealised']
    for name, wall in best.items():
        print(f'{name:>26} {wall:7.2f} s {size * duration / wall:8.1f}x per episode '
              f'{wall / reference:6.2f} x the idealised time', flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--populations', type=int, nargs='*',
                        default=[50, 500, 1000, 2000, 10000])
    parser.add_argument('--duration', type=float, default=400.0,
                        help='sim seconds per episode for N <= 500')
    parser.add_argument('--min-duration', type=float, default=60.0,
                        help='the shortest episode of a large swarm (sim seconds)')
    parser.add_argument('--seed', type=int, default=1)
    parser.add_argument('--no-split', action='store_true', help='skip the profiled runs')
    parser.add_argument('--profiles', action='store_true',
                        help="only the sensing-chain profiles' cost (ratios in one run)")
    parser.add_argument('--batch-sizes', type=int, nargs='*', default=[1, 4, 16, 64],
                        help='batch sizes of the batched engine (none: skip it)')
    parser.add_argument('--batch-populations', type=int, nargs='+', default=[10, 50])
    parser.add_argument('--batch-duration', type=float, default=400.0,
                        help='sim seconds per episode of the batched runs')
    args = parser.parse_args()
    base = load_config()
    run_episode(base.replace(episode={'population': 300, 'duration': 1.0}))  # compile kernels
    run_batch([base.replace(episode={'population': 5, 'duration': 1.0})] * 2)
    if args.profiles:
        profiles(base, args.batch_duration)
        return
    if args.batch_sizes:
        batched(base, args.batch_populations, args.batch_sizes, args.batch_duration,
                not args.no_split)
    if not args.populations:
        return
    print(f'embedded runner at the density of N = {REFERENCE_POPULATION} in the '
          f'{base.world.arena_side:g} m arena, seed {args.seed}, one core')
    # The CPU time of this process beside the wall time: on a shared machine the wall clock
    # counts other people's work too, and the CPU column says what the runner itself needed.
    print(f'{"N":>6} {"arena":>7} {"sim s":>6} {"wall s":>7} {"us/step":>8} {"x real time":>11}'
          f' {"x (CPU)":>8}  target')
    configs = {}
    for population in args.populations:
        duration = max(args.duration * min(1.0, 500 / max(population, 1)), args.min_duration)
        config = at_paper_density(base, population, min(duration, args.duration), args.seed)
        configs[population] = config
        cpu = time.process_time()
        result = run_episode(config)
        cpu = time.process_time() - cpu
        target = TARGETS.get(population)
        verdict = (f'{target:g}x: {"met" if result.real_time_factor >= target else "MISSED"}'
                   if target else '')
        print(f'{population:6d} {config.world.arena_side:6.1f}m {config.episode.duration:6g} '
              f'{result.wall_time:7.2f} {result.wall_time / result.steps * 1e6:8.1f} '
              f'{result.real_time_factor:10.1f}x {config.episode.duration / cpu:7.1f}x  {verdict}',
              flush=True)
    if args.no_split:
        return
    print('where a step goes (us per step, profiled run of the same episode; set-up apart):')
    names = (*PARTS, 'metrics samples')
    print(f'{"N":>6} ' + ' '.join(f'{name:>16}' for name in names) + f' {"total":>9}'
          f' {"set-up s":>9}')
    for population, config in configs.items():
        parts, setup = split(config)
        total = sum(parts.values())
        print(f'{population:6d} ' + ' '.join(
            f'{parts[name]:9.1f} ({parts[name] / total:3.0%})' for name in names)
            + f' {total:9.1f} {setup:9.2f}', flush=True)


if __name__ == '__main__':
    main()
