"""The optimisers an evolution design may name (``evolve.strategy``), each with ``ask()`` (a
generation's genomes), ``tell(genomes, scores)`` (lower is better) and ``sigma``, and each
pickled whole into the checkpoint, so a resumed run carries on with the same bits.

- ``cma_es``: pycma's CMA-ES (:func:`cma_es`), seeded through its ``seed`` option; it draws
  from numpy's global generator, whose state the loop keeps apart.
- ``openai_es``: the evolution strategy of Salimans et al. 2017 ("Evolution Strategies as a
  Scalable Alternative to Reinforcement Learning", arXiv:1703.03864), as in
  openai/evolution-strategies-starter (es_distributed/es.py, optimizers.py): antithetic
  pairs ``mean +- sigma * eps``, the scores turned into centred ranks in [-0.5, 0.5], the
  gradient estimate ``sum((rank+ - rank-) * eps) / genomes`` and an Adam step on it plus an
  L2 term (:class:`OpenAIES`). numpy only, on a generator of its own.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

#: The strategies a design may name.
STRATEGIES = ('cma_es', 'openai_es')
#: openai_es: the L2 coefficient, Adam's betas and epsilon (the starter's humanoid
#: configuration and its Adam defaults).
L2_COEFFICIENT = 0.005
BETA1, BETA2, EPSILON = 0.9, 0.999, 1e-8
#: openai_es: the stream of its generator (beside the training and held-out seeds').
NOISE_STREAM = 0x0E5


def cma_es(start: np.ndarray, sigma: float, genomes: int, seed: int,
           diagonal: bool = False) -> Any:
    """A seeded pycma CMA-ES with file logging and printing off, its mean at ``start``;
    ``genomes`` 0 leaves the population at pycma's default for the size (its ``popsize``
    option, 4 + 3 ln n) and ``diagonal`` keeps the covariance diagonal (its
    ``CMA_diagonal``: sep-CMA-ES)."""
    import cma

    options: dict[str, Any] = {'seed': seed, 'verb_log': 0, 'verbose': -9, 'verb_disp': 0}
    if genomes:
        options['popsize'] = genomes
    if diagonal:
        options['CMA_diagonal'] = True
    return cma.CMAEvolutionStrategy(np.array(start, dtype=np.float64), sigma, options)


def centred_ranks(scores: Sequence[float]) -> np.ndarray:
    """Each score's rank scaled to [-0.5, 0.5] (ties in the order given)."""
    values = np.asarray(scores, dtype=np.float64)
    ranks = np.empty(len(values))
    ranks[np.argsort(values, kind='stable')] = np.arange(len(values), dtype=np.float64)
    return ranks / (len(values) - 1) - 0.5


class OpenAIES:
    """OpenAI-ES over a genome of ``size`` weights, its mean starting at ``start`` (zero if
    not given).

    ``genomes`` (even) per generation: ``genomes / 2`` noise vectors, each asked as
    ``mean + sigma * eps`` (the first half) and ``mean - sigma * eps`` (the second). ``sigma``
    stays as given; ``learning_rate`` is Adam's step size.
    """

    def __init__(self, size: int, sigma: float, genomes: int, seed: int,
                 learning_rate: float, start: np.ndarray | None = None) -> None:
        """A seeded strategy.

        Raises:
            ValueError: ``genomes`` is odd (the pairs are antithetic).
        """
        if genomes % 2:
            raise ValueError(f'openai_es needs an even number of genomes, not {genomes}')
        self.mean = np.zeros(size) if start is None else np.array(start, dtype=np.float64)
        self.sigma = float(sigma)
        self.genomes = genomes
        self.learning_rate = float(learning_rate)
        self.rng = np.random.default_rng([seed, NOISE_STREAM])
        self.m = np.zeros(size)
        self.v = np.zeros(size)
        self.t = 0
        self._noise: np.ndarray | None = None

    def ask(self) -> list[np.ndarray]:
        """This generation's genomes: the positive halves of the pairs, then the negative."""
        noise = self.rng.standard_normal((self.genomes // 2, self.mean.size))
        self._noise = noise
        return [self.mean + self.sigma * e for e in noise] + \
            [self.mean - self.sigma * e for e in noise]

    def tell(self, genomes: Sequence[np.ndarray], scores: Sequence[float]) -> None:
        """Move the mean against the scores' gradient estimate (lower is better).

        Raises:
            ValueError: ``genomes`` are not the ones last asked.
        """
        noise = self._noise
        if noise is None or len(genomes) != self.genomes or not np.array_equal(
                genomes[0], self.mean + self.sigma * noise[0]):
            raise ValueError('tell() takes the genomes of the last ask(), in order')
        ranks = centred_ranks(scores)
        half = self.genomes // 2
        weights = ranks[:half] - ranks[half:]
        # An elementwise product summed down the rows: a fixed order, no BLAS.
        gradient = (weights[:, None] * noise).sum(axis=0) / self.genomes
        step = gradient + L2_COEFFICIENT * self.mean
        self.t += 1
        a = self.learning_rate * np.sqrt(1 - BETA2 ** self.t) / (1 - BETA1 ** self.t)
        self.m = BETA1 * self.m + (1 - BETA1) * step
        self.v = BETA2 * self.v + (1 - BETA2) * (step * step)
        self.mean = self.mean - a * self.m / (np.sqrt(self.v) + EPSILON)
        self._noise = None


def new_strategy(name: str, start: np.ndarray, sigma: float, genomes: int, seed: int,
                 learning_rate: float, diagonal: bool = False) -> Any:
    """The strategy ``name`` (:data:`STRATEGIES`) for a fresh run, its mean at ``start``."""
    if name == 'openai_es':
        return OpenAIES(len(start), sigma, genomes, seed, learning_rate, start)
    return cma_es(start, sigma, genomes, seed, diagonal)
