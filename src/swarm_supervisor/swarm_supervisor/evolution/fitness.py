"""A generation's fitness: every genome on the generation's training seeds, in batches.

A genome becomes a weights file and a parameter set of the design's controller kind
(:mod:`swarm_supervisor.evolution.genomes`); its fitness is the mean over its episodes of
the episode's mean cue fraction over time (the metrics' ``mean_cue_fraction`` at every
sample: lower is better, a cleaner arena). The episodes of all genomes are cut into batches
of at most ``design.batch`` and run with the batched engine
(:func:`~swarm_supervisor.engine.runner.run_batch`), in this process or on a pool of
worker processes or a Dask cluster's workers; a robot computes the same bits in any batch,
so the fitness does not depend on how the episodes are cut or where they run.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.runner import run_batch
from swarm_supervisor.evolution.design import Design
from swarm_supervisor.evolution.genomes import architecture, save_genome

#: The metric a genome is scored on (swarm_metrics.metrics).
METRIC = 'mean_cue_fraction'


def training_seeds(design: Design, generation: int) -> list[int]:
    """The episode seeds of ``generation`` (the same for all its genomes, fresh each
    generation), derived from the design's seed alone, so a resumed run draws the same."""
    rng = np.random.default_rng([design.seed, 0xE70, generation])
    return [int(seed) for seed in rng.integers(1, 2**31 - 1, design.episodes)]


def genome_config(design: Design, weights: str | Path, seed: int) -> SwarmConfig:
    """The parameter set of one episode of the genome whose weights file is ``weights``."""
    return design.base.replace(
        episode={'population': design.robots, 'duration': design.duration, 'seed': seed},
        controller=architecture(design.kind).section(design, str(weights)))


def episode_fitness(metrics: Sequence[dict[str, float]]) -> float:
    """The mean of :data:`METRIC` over an episode's samples."""
    return math.fsum(row[METRIC] for row in metrics) / len(metrics)


def run_configs(configs: Sequence[SwarmConfig]) -> list[float]:
    """Each episode's fitness, the episodes stepped together (a worker's task)."""
    return [episode_fitness(result.metrics) for result in run_batch(configs)]


def generation_configs(design: Design, genomes: np.ndarray, generation: int,
                       folder: Path) -> list[SwarmConfig]:
    """Every episode of a generation, genome after genome (seeds in order within each),
    writing each genome's weights into ``folder``."""
    return genome_configs(design, genomes, training_seeds(design, generation), folder)


def genome_configs(design: Design, genomes: np.ndarray, seeds: Sequence[int], folder: Path,
                   name: str = 'genome') -> list[SwarmConfig]:
    """Every genome on every one of ``seeds``, genome after genome, each genome's weights
    written into ``folder`` as ``{name}_{i}.npz``."""
    folder.mkdir(parents=True, exist_ok=True)
    configs: list[SwarmConfig] = []
    for i, genome in enumerate(genomes):
        path = folder / f'{name}_{i}.npz'
        save_genome(design, genome, path)
        configs.extend(genome_config(design, path, seed) for seed in seeds)
    return configs


def batches(configs: Sequence[SwarmConfig], size: int, jobs: int) -> list[list[SwarmConfig]]:
    """Cut the episodes into at least ``jobs`` batches (when there are as many) of at most
    ``size``, in order."""
    count = max(jobs, math.ceil(len(configs) / size))
    per = math.ceil(len(configs) / count)
    return [list(configs[k:k + per]) for k in range(0, len(configs), per)]


def run_scores(configs: Sequence[SwarmConfig], size: int, pool: Any | None,
               jobs: int, func: Callable[[list[SwarmConfig]], list[Any]] = run_configs
               ) -> list[Any]:
    """Each episode's fitness (or what ``func`` makes of a batch), in order, in batches of
    at most ``size`` on ``pool`` (a multiprocessing pool of ``jobs`` processes or a
    :class:`~swarm_supervisor.evolution.cluster.ClusterPool`) or in this process."""
    cut = batches(configs, size, jobs)
    if pool is None:
        scores = [func(batch) for batch in cut]
    else:
        scores = pool.map(func, cut, chunksize=1)
    return [score for batch in scores for score in batch]


def evaluate(design: Design, genomes: np.ndarray, generation: int, folder: Path,
             pool: Any | None, jobs: int) -> list[float]:
    """Each genome's fitness (the mean over its episodes), on ``pool`` (a
    multiprocessing pool of ``jobs`` processes) or in this process."""
    flat = run_scores(generation_configs(design, genomes, generation, folder), design.batch,
                      pool, jobs)
    per = design.episodes
    return [math.fsum(flat[i * per:(i + 1) * per]) / per for i in range(len(genomes))]
