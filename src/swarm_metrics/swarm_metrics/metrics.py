"""The study's metrics (method.md), computed from a cue raster and robot positions.

Pure functions, so the embedded runner, the metrics node and bag analysis compute every number
the same way.
"""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np

from mona_controller.schema import param, validate

#: Column order of metrics.csv and of the metrics topics.
COLUMNS = ('t', 'mean_cue', 'mean_cue_fraction', 'ratio_near_source', 'coherency')
#: Up to this many robots, coherency takes every pair's distance at once and numpy's mean of
#: them, as it always has: the shipped study (N <= 50) keeps its numbers bit for bit. Larger
#: swarms use a compiled loop that never holds the N^2 / 2 distances (10,000 robots: 50
#: million pairs, 1.2 GB as arrays), equal to the all-pairs mean to about 1e-13 (relative).
ALL_PAIRS_MAX = 200


@dataclasses.dataclass(frozen=True)
class MetricsParams:
    """How the metrics are taken."""

    source_radius: float = param(0.7, unit='m', low=0.0, high=100.0,
                                 doc='r_c: a robot within this distance of the cue centre '
                                     'counts as near the source')
    sample_period: float = param(1.0, unit='s', low=0.001, high=3600.0,
                                 doc='how often the metrics are sampled (sim time)')

    def __post_init__(self) -> None:
        validate(self, 'metrics.')


def mean_cue(cue: np.ndarray) -> float:
    """The arena mean of the cue raster, in cue units (0..255)."""
    return float(cue.mean(dtype=np.float64))


def ratio_near_source(positions: np.ndarray, centre: tuple[float, float],
                      radius: float) -> float:
    """The fraction of robots within ``radius`` of ``centre`` (nan with no robots)."""
    if len(positions) == 0:
        return float('nan')
    distance = np.hypot(positions[:, 0] - centre[0], positions[:, 1] - centre[1])
    return float(np.count_nonzero(distance <= radius) / len(positions))


def coherency(positions: np.ndarray) -> float:
    """The mean distance between all pairs of robots (m); nan with fewer than two robots."""
    n = len(positions)
    if n < 2:
        return float('nan')
    if n <= ALL_PAIRS_MAX:
        i, j = np.triu_indices(n, k=1)
        return float(np.hypot(positions[i, 0] - positions[j, 0],
                              positions[i, 1] - positions[j, 1]).mean())
    xy = np.asarray(positions, dtype=np.float64)
    rows = _row_distance_sums(np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1]))
    return float(rows.sum() / (n * (n - 1) // 2))


# 'reassoc' only: the sum of a row may be added in any order (so LLVM vectorises the square
# roots), but NaN and inf keep their meaning. Each row is at most N - 1 terms, and numpy's
# pairwise sum adds the rows, so the rounding error stays near N * 1e-16.
@numba.njit(cache=True, fastmath={'reassoc'})
def _row_distance_sums(x: np.ndarray, y: np.ndarray) -> np.ndarray:  # pragma: no cover - jit
    """Row i: the sum of the distances from robot i to robots i + 1 .. N - 1."""
    n = x.shape[0]
    rows = np.zeros(n)
    for i in range(n - 1):
        xi, yi = x[i], y[i]
        total = 0.0
        for j in range(i + 1, n):
            dx, dy = x[j] - xi, y[j] - yi
            total += math.sqrt(dx * dx + dy * dy)
        rows[i] = total
    return rows


def sample(t: float, cue: np.ndarray, initial_mean: float, positions: np.ndarray,
           centre: tuple[float, float], params: MetricsParams) -> dict[str, float]:
    """One metrics row (the columns of :data:`COLUMNS`)."""
    level = mean_cue(cue)
    return {
        't': t,
        'mean_cue': level,
        'mean_cue_fraction': level / initial_mean if initial_mean > 0 else float('nan'),
        'ratio_near_source': ratio_near_source(positions, centre, params.source_radius),
        'coherency': coherency(positions),
    }
