"""The study's metrics (method.md), computed from a cue raster and robot positions.

Pure functions, so the embedded runner, the metrics node and bag analysis compute every number
the same way.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import TYPE_CHECKING

import numba
import numpy as np

from mona_controller.schema import param, validate

if TYPE_CHECKING:  # the field is the world's; metrics only read it
    from swarm_world.field import CueField

#: Column order of metrics.csv and of the metrics topics.
COLUMNS = ('t', 'mean_cue', 'mean_cue_fraction', 'ratio_near_source', 'coherency')
#: With more than one source, metrics.csv adds two columns per source (its name filled in):
#: the share of the initial cue left in the cells nearest to it, and the fraction of robots
#: within r_c of it that have no nearer source. Each pair sums to its column of COLUMNS.
SOURCE_COLUMNS = ('mean_cue_fraction_{}', 'ratio_near_{}')
#: Up to this many robots, coherency takes every pair's distance at once and numpy's mean of
#: them, as it always has: the shipped study (N <= 50) keeps its numbers bit for bit. Larger
#: swarms use a compiled loop that never holds the N^2 / 2 distances (10,000 robots: 50
#: million pairs, 1.2 GB as arrays), equal to the all-pairs mean to about 1e-13 (relative).
ALL_PAIRS_MAX = 200


@dataclasses.dataclass(frozen=True)
class MetricsParams:
    """How the metrics are taken."""

    source_radius: float = param(0.7, unit='m', low=0.0, high=100.0,
                                 doc='r_c: a robot within this distance of the nearest '
                                     'source counts as near the source')
    sample_period: float = param(1.0, unit='s', low=0.001, high=3600.0,
                                 doc='how often the metrics are sampled (sim time)')

    def __post_init__(self) -> None:
        validate(self, 'metrics.')


def mean_cue(cue: np.ndarray) -> float:
    """The arena mean of the cue raster, in cue units (0..255)."""
    return float(cue.mean(dtype=np.float64))


def nearest(points: np.ndarray, sources: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each point [P, 2]: the index of its nearest source [S, 2] and the distance (m)."""
    distance = np.hypot(points[:, 0, None] - sources[None, :, 0],
                        points[:, 1, None] - sources[None, :, 1])
    which = distance.argmin(axis=1)
    return which, distance[np.arange(len(points)), which]


def ratio_near_source(positions: np.ndarray, sources: np.ndarray, radius: float) -> float:
    """The fraction of robots within ``radius`` of their nearest source (nan with no robots).

    ``sources`` is [S, 2] (or one (x, y) pair)."""
    if len(positions) == 0:
        return float('nan')
    sources = np.asarray(sources, dtype=np.float64).reshape(-1, 2)
    if len(sources) == 1:  # the paper's case, without the nearest-source search
        distance = np.hypot(positions[:, 0] - sources[0, 0], positions[:, 1] - sources[0, 1])
    else:
        _, distance = nearest(positions, sources)
    return float(np.count_nonzero(distance <= radius) / len(positions))


# 'reassoc': each row's sums may be added in any order (so LLVM vectorises them); the rows
# are then added in order. Deterministic for a given build, like the coherency's row sums.
@numba.njit(cache=True, fastmath={'reassoc'})
def region_totals(cue: np.ndarray, cell_size: float, sx: np.ndarray,
                  sy: np.ndarray) -> np.ndarray:  # pragma: no cover - jit
    """The cue summed (float64) over each source's region: the cells whose centre is nearer
    to that source (at ``sx``, ``sy``) than to any other (the first on a tie)."""
    rows, cols = cue.shape
    count = sx.shape[0]
    # Squared offsets per axis, once: a cell's squared distance is then one addition.
    dx2 = np.empty((count, cols))
    for k in range(count):
        for j in range(cols):
            dx2[k, j] = ((j + 0.5) * cell_size - sx[k]) ** 2
    best = np.empty(cols)
    which = np.empty(cols, dtype=np.int64)
    totals = np.zeros(count)
    for i in range(rows):
        y = (i + 0.5) * cell_size
        for j in range(cols):  # branch-free passes, so each vectorises
            best[j] = dx2[0, j] + (y - sy[0]) ** 2
            which[j] = 0
        for k in range(1, count):
            dy2 = (y - sy[k]) ** 2
            for j in range(cols):
                d = dx2[k, j] + dy2
                closer = d < best[j]
                best[j] = d if closer else best[j]
                which[j] = k if closer else which[j]
        for k in range(count):
            row = 0.0
            for j in range(cols):
                row += np.float64(cue[i, j]) if which[j] == k else 0.0
            totals[k] += row
    return totals


def source_columns(cue: np.ndarray, cell_size: float, initial_mean: float,
                   positions: np.ndarray, sources: np.ndarray, names: tuple[str, ...],
                   radius: float) -> dict[str, float]:
    """The per-source columns (:data:`SOURCE_COLUMNS`) of one sample: each source's region is
    the cells nearer to it than to any other source, where the sources are now."""
    totals = region_totals(cue, cell_size, np.ascontiguousarray(sources[:, 0]),
                           np.ascontiguousarray(sources[:, 1]))
    scale = cue.size * initial_mean
    near = np.zeros(len(names), dtype=np.int64)
    if len(positions):
        robot, distance = nearest(positions, sources)
        near = np.bincount(robot[distance <= radius], minlength=len(names))
    out = {}
    for k, name in enumerate(names):
        out[SOURCE_COLUMNS[0].format(name)] = (float(totals[k] / scale) if scale > 0
                                               else float('nan'))
        out[SOURCE_COLUMNS[1].format(name)] = (float(near[k] / len(positions))
                                               if len(positions) else float('nan'))
    return out


def coherency(positions: np.ndarray) -> float:
    """The mean distance between all pairs of robots (m); nan with fewer than two robots."""
    n = len(positions)
    if n < 2:
        return float('nan')
    if n <= ALL_PAIRS_MAX:
        i, j = _pairs(n)
        return float(np.hypot(positions[i, 0] - positions[j, 0],
                              positions[i, 1] - positions[j, 1]).mean())
    xy = np.asarray(positions, dtype=np.float64)
    rows = _row_distance_sums(np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1]))
    return float(rows.sum() / (n * (n - 1) // 2))


@functools.lru_cache(maxsize=64)
def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Every pair (i < j) of n robots, as index arrays (cached: a sample takes them anew
    otherwise, almost half of its coherency's cost)."""
    i, j = np.triu_indices(n, k=1)
    i.setflags(write=False)
    j.setflags(write=False)
    return i, j


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
           sources: np.ndarray, params: MetricsParams, names: tuple[str, ...] = (),
           cell_size: float = 0.0) -> dict[str, float]:
    """One metrics row: the columns of :data:`COLUMNS`, then with more than one source in
    ``names`` (and their places ``sources`` [S, 2] now) its :data:`SOURCE_COLUMNS`."""
    level = mean_cue(cue)
    sources = np.asarray(sources, dtype=np.float64).reshape(-1, 2)
    row = {
        't': t,
        'mean_cue': level,
        'mean_cue_fraction': level / initial_mean if initial_mean > 0 else float('nan'),
        'ratio_near_source': ratio_near_source(positions, sources, params.source_radius),
        'coherency': coherency(positions),
    }
    if len(names) > 1:
        row.update(source_columns(cue, cell_size, initial_mean, positions, sources, names,
                                  params.source_radius))
    return row


def source_names(columns: list[str] | tuple[str, ...]) -> list[str]:
    """The sources named by per-source columns among ``columns`` (in column order)."""
    prefix = SOURCE_COLUMNS[0].format('')
    return [c[len(prefix):] for c in columns if c.startswith(prefix) and c not in COLUMNS]


def is_source_column(column: str) -> bool:
    """Whether ``column`` is one of the per-source columns (:data:`SOURCE_COLUMNS`)."""
    return column not in COLUMNS and any(
        column.startswith(pattern.format('')) for pattern in SOURCE_COLUMNS)


def sample_field(t: float, field: CueField, positions: np.ndarray,
                 params: MetricsParams) -> dict[str, float]:
    """:func:`sample` of an episode's cue field (its cue, initial mean, and its sources where
    they are at ``t``): what the embedded runner and every replica of the cue record."""
    return sample(t, field.cue, field.initial_mean, positions, field.source_positions(t),
                  params, field.names, field.params.cell_size)


def columns(names: tuple[str, ...]) -> tuple[str, ...]:
    """The metrics.csv columns of an episode whose sources are ``names``."""
    if len(names) < 2:
        return COLUMNS
    return COLUMNS + tuple(c.format(name) for name in names for c in SOURCE_COLUMNS)
