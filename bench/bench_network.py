"""Benchmark: the network controller's cost per robot-step against BEECLUST's, in the batched
engine (N = 30, K = 16 episodes by default, the study's batch size).

Each round runs the same batch (seeds 1..K, the shipped parameter file) once with
``controller.kind: beeclust`` and once with ``network`` (weights drawn from its seed,
``--hidden`` neurons, ``--recurrent`` or not), alternating; the best of ``--rounds`` rounds
counts. It prints microseconds per robot-step of the whole engine (sensing, controller,
physics, metrics) and of the controller's step alone (the merged controller stepped on
recorded readings), and the ratio. Target: network at most 2x BEECLUST per robot-step.

    .venv/bin/python bench/bench_network.py [--population 30] [--batch 16]
        [--duration 200] [--hidden 8] [--recurrent] [--rounds 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mona_controller.controllers import make_controller, random_readings
from swarm_supervisor.config import SwarmConfig, load_config
from swarm_supervisor.engine.runner import run_batch


def configs(base: SwarmConfig, kind: str, args: argparse.Namespace) -> list[SwarmConfig]:
    """The batch's episodes with the controller ``kind``."""
    return [base.replace(episode={'population': args.population, 'duration': args.duration,
                                  'seed': seed},
                         controller={'kind': kind, 'network': {'hidden': args.hidden,
                                                               'recurrent': args.recurrent}})
            for seed in range(1, args.batch + 1)]


def engine_cost(batch: list[SwarmConfig]) -> float:
    """Microseconds per robot-step of one batched run."""
    started = time.perf_counter()
    results = run_batch(batch)
    spent = time.perf_counter() - started
    return spent * 1e6 / sum(r.steps * r.config.episode.population for r in results)


def controller_cost(config: SwarmConfig, robots: int, steps: int = 2000) -> float:
    """Microseconds per robot-step of one controller of ``robots`` robots alone."""
    controller = make_controller(config.controller, config.mona, range(robots))
    rng = np.random.default_rng(0)
    readings = [random_readings(rng, robots, config.mona.ir_count) for _ in range(64)]
    now = np.zeros(robots)
    controller.step(*readings[0], now)  # compile
    started = time.perf_counter()
    for step in range(steps):
        controller.step(*readings[step % 64], now + step * 0.25)
    return (time.perf_counter() - started) * 1e6 / (steps * robots)


def main() -> None:
    """Measure and print both kinds."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--population', type=int, default=30)
    parser.add_argument('--batch', type=int, default=16)
    parser.add_argument('--duration', type=float, default=200.0)
    parser.add_argument('--hidden', type=int, default=8)
    parser.add_argument('--recurrent', action='store_true')
    parser.add_argument('--rounds', type=int, default=3)
    args = parser.parse_args()
    base = load_config()
    batches = {kind: configs(base, kind, args) for kind in ('beeclust', 'network')}
    for batch in batches.values():  # warm up: compile the kernels
        run_batch(batch[:1])
    engine = {kind: min(engine_cost(batch) for _ in range(args.rounds))
              for kind, batch in batches.items()}
    robots = args.population * args.batch
    alone = {kind: controller_cost(batch[0], robots) for kind, batch in batches.items()}
    print(f'N = {args.population}, K = {args.batch}, {args.duration:g} s, hidden '
          f'{args.hidden}{" recurrent" if args.recurrent else ""}')
    for kind in batches:
        print(f'  {kind:9s} engine {engine[kind]:6.3f} us/robot-step '
              f'({1 / engine[kind]:5.2f} M robot-steps/s), controller step '
              f'{alone[kind]:6.3f} us/robot-step')
    ratio = engine['network'] / engine['beeclust']
    print(f'  network / beeclust: engine {ratio:.2f}x (target <= 2x), controller '
          f'{alone["network"] / alone["beeclust"]:.2f}x')


if __name__ == '__main__':
    main()
