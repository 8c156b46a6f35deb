"""Choosing the genome to ship: the optimiser's mean, scored on a fixed validation set.

A generation's best training score is the minimum of noisy estimates (a few episodes each),
so it is biased low and its genome is often lucky rather than good: a winner's curse. The
evolution therefore ships the optimiser's *mean* (the distribution's centre: pycma's
``mean``, which its documentation considers "the best available estimate of the optimal
solution"; OpenAI-ES's ``mean``), scored every ``validate_every`` generations on the same
``validation`` seeds, and chooses the mean with the lowest validation score. The validation
seeds are drawn from [2^31, 2^32), where no training seed and no held-out seed lies (those
are drawn from [1, 2^31 - 1) and [2^32, 2^33)), so the sets are disjoint by construction.

The run stops once ``patience`` validations in a row have not improved on the best one
(:func:`stopped`): the validation score has stopped improving.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np

from swarm_supervisor.evolution.design import Design
from swarm_supervisor.evolution.fitness import genome_configs, run_scores

#: The stream of the validation seeds, and where they lie.
VALIDATION_STREAM = 0x7A1
LOW, HIGH = 2**31, 2**32


def validation_seeds(design: Design) -> list[int]:
    """The design's ``validation`` seeds (distinct, the same for every generation)."""
    rng = np.random.default_rng([design.seed, VALIDATION_STREAM])
    seeds: list[int] = []
    while len(seeds) < design.validation:
        seed = int(rng.integers(LOW, HIGH))
        if seed not in seeds:
            seeds.append(seed)
    return seeds


def due(design: Design, generation: int) -> bool:
    """Whether the mean is validated after ``generation`` (0-based)."""
    return bool(design.validation) and (generation + 1) % design.validate_every == 0


def validate(design: Design, mean: np.ndarray, folder: Path, pool: Any | None,
             jobs: int) -> float:
    """The mean's validation score: its fitness averaged over the validation seeds, each an
    episode of ``validation_duration`` (or the training ``duration``)."""
    if design.validation_duration:
        design = dataclasses.replace(design, duration=design.validation_duration)
    configs = genome_configs(design, np.array([mean]), validation_seeds(design), folder,
                             name='mean')
    scores = run_scores(configs, design.batch, pool, jobs)
    return math.fsum(scores) / len(scores)


def stopped(design: Design, validations: list[tuple[int, float]]) -> bool:
    """Whether the last ``patience`` validations (generation, score) all failed to improve
    on the best before them (never with ``patience`` 0)."""
    if not design.patience or len(validations) <= design.patience:
        return False
    scores = [score for _, score in validations]
    return min(scores[-design.patience:]) >= min(scores[:-design.patience])
