"""The study's metrics (docs/model.md), computed from a cue raster and robot positions.

Each metric is a declared entry, :class:`Metric` (name, unit, doc, the function that computes
it from one sample's inputs, its plot label), in one table, :data:`METRICS`. Everything else
is derived from that table: the metrics.csv columns (in table order after ``t``), the
``/metrics/<name>`` topics the metrics node publishes and every bag records, the completeness
checks of the online samples, the live view's channels, the video's plots (entries with a
label), the names a claim may test and the study's figures beyond the paper's. So a metric is
added in one place: :func:`register` (docs/bags.md, "Adding a metric", says where it must run).

Pure functions, so the embedded runner, the metrics node and bag analysis compute every number
the same way.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
from collections.abc import Callable
from typing import TYPE_CHECKING

import numba
import numpy as np

from mona_controller.schema import param, validate
from swarm_metrics.plugins import measure

if TYPE_CHECKING:  # the field is the world's; metrics only read it
    from swarm_world.field import CueField

#: The paper's columns of metrics.csv: t and the four built-in metrics, always first and in
#: this order (registered metrics follow them: :func:`metric_columns`).
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
#: What a metric's name may be: a ROS topic name token (it becomes /metrics/<name>).
NAME_PATTERN = re.compile(r'[A-Za-z][A-Za-z0-9_]*')


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


# The two sum kernels below fix the order of every addition in the source (no fastmath
# 'reassoc'), so their results are the same bits on any CPU: with 'reassoc' LLVM chose the
# order by the CPU's vector width, and a per-source column differed between an AVX2 and an
# AVX-512 machine. The terms go into a buffer first (that loop still vectorises), then
# _ordered_sum adds them in a fixed order.
@numba.njit(cache=True)
def _ordered_sum(terms: np.ndarray, count: int) -> float:  # pragma: no cover - jit
    """The sum of ``terms[:count]`` in four interleaved partial sums, added in order."""
    a0 = a1 = a2 = a3 = 0.0
    k = 0
    while k + 4 <= count:
        a0 += terms[k]
        a1 += terms[k + 1]
        a2 += terms[k + 2]
        a3 += terms[k + 3]
        k += 4
    total = (a0 + a1) + (a2 + a3)
    while k < count:
        total += terms[k]
        k += 1
    return total


@numba.njit(cache=True)
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
    terms = np.empty(cols)
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
            for j in range(cols):
                terms[j] = np.float64(cue[i, j]) if which[j] == k else 0.0
            totals[k] += _ordered_sum(terms, cols)
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


# Each row's distances summed by _ordered_sum: the same bits on any CPU. A row is at most
# N - 1 terms, and numpy's pairwise sum adds the rows, so the rounding error stays near
# N * 1e-16.
@numba.njit(cache=True)
def _row_distance_sums(x: np.ndarray, y: np.ndarray) -> np.ndarray:  # pragma: no cover - jit
    """Row i: the sum of the distances from robot i to robots i + 1 .. N - 1."""
    n = x.shape[0]
    rows = np.zeros(n)
    distances = np.empty(n)
    for i in range(n - 1):
        xi, yi = x[i], y[i]
        count = n - i - 1
        for k in range(count):
            dx, dy = x[i + 1 + k] - xi, y[i + 1 + k] - yi
            distances[k] = math.sqrt(dx * dx + dy * dy)
        rows[i] = _ordered_sum(distances, count)
    return rows


@dataclasses.dataclass(slots=True)  # not frozen: built once a sample, and frozen costs 4x
class Sample:
    """What one metrics sample is computed from: a metric's ``compute`` takes this (and must
    not change it: the metrics after it read the same inputs)."""

    t: float  #: s since the episode's start
    cue: np.ndarray  #: the cue raster [rows, cols] (row i at y = (i + 0.5) * cell_size)
    initial_mean: float  #: the arena mean cue at t = 0
    positions: np.ndarray  #: [N, 2] robot positions (m, world frame)
    sources: np.ndarray  #: [S, 2] where the sources are at t (m)
    params: MetricsParams
    cell_size: float  #: m per raster cell (0 when the caller does not know it)
    mean_cue: float  #: the arena mean cue, computed once (two built-in metrics use it)


@dataclasses.dataclass(frozen=True)
class Metric:
    """One metric: a column of metrics.csv and the topic ``/metrics/<name>``.

    ``compute`` must be a pure function of the sample (the embedded runner, the metrics
    node's replica and ``mona-swarm analyze`` each call it on their own inputs and must get
    the same number, compared with ``==``), cheap (it runs once per simulated second) and
    return a float (NaN where undefined).
    """

    name: str  #: column and topic name (:data:`NAME_PATTERN`)
    unit: str  #: '' for a fraction in [0, 1] (plots span 0..1.05), else the unit, e.g. 'm'
    doc: str  #: one line
    compute: Callable[[Sample], float]
    label: str | None = None  #: the axis label where it is plotted (None: not plotted)


def _fraction(sample: Sample) -> float:
    return sample.mean_cue / sample.initial_mean if sample.initial_mean > 0 else float('nan')


#: The metrics, in column order: the paper's four, then any registered ones.
METRICS: dict[str, Metric] = {metric.name: metric for metric in (
    Metric('mean_cue', 'cue units (0..255)', 'arena mean cue',
           lambda sample: sample.mean_cue),
    Metric('mean_cue_fraction', '', 'the arena mean cue over its initial value', _fraction,
           'mean cue / initial'),
    Metric('ratio_near_source', '',
           'fraction of robots within source_radius of the nearest source',
           lambda sample: ratio_near_source(sample.positions, sample.sources,
                                            sample.params.source_radius),
           'ratio near source'),
    Metric('coherency', 'm', 'mean pairwise distance between the robots',
           lambda sample: coherency(sample.positions), 'coherency (m)'),
)}
#: The paper's metrics (built in: never unregistered; figs. 4-6 draw them).
PAPER_METRICS = tuple(METRICS)


def register(metric: Metric) -> Metric:
    """Add ``metric`` to :data:`METRICS` (after those there).

    Takes effect in this process for everything computed or recorded from then on; another
    process (a study worker, the metrics node) has it only if it registers it too:
    call it in a plug-in (:mod:`mona_controller.plugins`), which every process loads.

    Returns:
        ``metric`` (so a module can keep it).

    Raises:
        ValueError: a bad name (one a per-source column could have included), or another
            metric of that name is registered.
    """
    if not NAME_PATTERN.fullmatch(metric.name) or metric.name == 't' or any(
            metric.name.startswith(pattern.format('')) for pattern in SOURCE_COLUMNS):
        raise ValueError(f'a metric name must match {NAME_PATTERN.pattern}, and be neither t '
                         f'nor a per-source column name, not {metric.name!r}')
    known = METRICS.get(metric.name)
    if known is not None and known != metric:
        raise ValueError(f'a metric named {metric.name!r} is registered already')
    METRICS[metric.name] = metric
    return metric


def unregister(name: str) -> None:
    """Remove a registered metric (not one of :data:`PAPER_METRICS`; unknown: nothing)."""
    if name in PAPER_METRICS:
        raise ValueError(f"{name} is one of the paper's metrics and cannot be removed")
    METRICS.pop(name, None)


def metric_names() -> tuple[str, ...]:
    """The metrics now in the table, in column order (metrics.csv less 't')."""
    return tuple(METRICS)


def metric_columns() -> tuple[str, ...]:
    """The metrics.csv columns of a one-source episode: 't', then :func:`metric_names`."""
    return ('t', *METRICS)


def plotted() -> tuple[tuple[str, str], ...]:
    """(name, axis label) of each metric that is plotted, in table order."""
    return tuple((metric.name, metric.label) for metric in METRICS.values()
                 if metric.label is not None)


def sample(t: float, cue: np.ndarray, initial_mean: float, positions: np.ndarray,
           sources: np.ndarray, params: MetricsParams, names: tuple[str, ...] = (),
           cell_size: float = 0.0) -> dict[str, float]:
    """One metrics row: 't' and each metric of :data:`METRICS`, then with more than one
    source in ``names`` (and their places ``sources`` [S, 2] now) its :data:`SOURCE_COLUMNS`."""
    sources = np.asarray(sources, dtype=np.float64).reshape(-1, 2)
    inputs = Sample(t, cue, initial_mean, positions, sources, params, cell_size,
                    mean_cue(cue))
    row = {'t': t}
    for name, metric in METRICS.items():
        row[name] = measure(metric, inputs)
    if len(names) > 1:
        row.update(source_columns(cue, cell_size, initial_mean, positions, sources, names,
                                  params.source_radius))
    return row


def source_names(columns: list[str] | tuple[str, ...]) -> list[str]:
    """The sources named by per-source columns among ``columns`` (in column order)."""
    prefix = SOURCE_COLUMNS[0].format('')
    return [c[len(prefix):] for c in columns if c.startswith(prefix) and c not in METRICS]


def is_source_column(column: str) -> bool:
    """Whether ``column`` is one of the per-source columns (:data:`SOURCE_COLUMNS`)."""
    return column != 't' and column not in METRICS and any(
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
        return metric_columns()
    return metric_columns() + tuple(c.format(name) for name in names for c in SOURCE_COLUMNS)
