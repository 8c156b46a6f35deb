"""Leak sources: where the cue comes from, how each is shaped, and how it moves in sim time.

The paper has one source, a linear disc at the arena centre (``world.cue_diameter``,
``world.cue_peak``). ``world.sources`` names any number of them instead, each with a position,
radius, peak and profile; optionally each moves (constant velocity, reflecting at the walls,
or a closed waypoint path) and leaks (:mod:`swarm_world.transport` restores its profile).
A source's position is a pure function of sim time, so every runner, the metrics node and bag
analysis put it in the same place.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numba
import numpy as np

from mona_controller.schema import ParameterError

PROFILES = ('linear', 'gaussian')
#: A Gaussian source has sigma = radius / GAUSSIAN_SIGMAS and is cut to 0 beyond its radius.
GAUSSIAN_SIGMAS = 3.0
#: The name of the paper's single source when ``world.sources`` is empty.
PAPER_SOURCE = 'source'


@dataclasses.dataclass(frozen=True)
class Source:
    """One leak source (SI units, world frame)."""

    name: str
    x: float  #: m, position at t = 0
    y: float  #: m
    radius: float  #: m, where the profile reaches 0
    peak: float  #: cue units at the centre
    profile: str = 'linear'  #: 'linear' (the paper's disc) or 'gaussian'
    emission: float = 0.0  #: cue units per second restored at the peak (0: does not leak)
    velocity: tuple[float, float] = (0.0, 0.0)  #: m/s, reflecting at the walls
    path_speed: float = 0.0  #: m/s along ``path`` (a closed loop from (x, y))
    path: tuple[tuple[float, float], ...] = ()  #: waypoints (m) after the start

    @property
    def moves(self) -> bool:
        """Whether the source's position changes with time."""
        return bool(self.path and self.path_speed) or self.velocity != (0.0, 0.0)

    def position(self, t: float, arena_side: float) -> tuple[float, float]:
        """Where the source is at sim time ``t`` (s)."""
        if self.path and self.path_speed:
            return _along_loop(((self.x, self.y), *self.path), self.path_speed * t)
        vx, vy = self.velocity
        return (_reflect(self.x + vx * t, arena_side), _reflect(self.y + vy * t, arena_side))

    def deposit(self, cells: int, cell_size: float, t: float, arena_side: float) -> np.ndarray:
        """The source's profile on the whole raster (float64 cue units) at time ``t``."""
        return self.window(cells, cell_size, t, arena_side, whole=True)[1]

    def window(self, cells: int, cell_size: float, t: float, arena_side: float,
               whole: bool = False) -> tuple[tuple[slice, slice], np.ndarray]:
        """The raster window (rows, cols) that covers the source's disc at time ``t`` and its
        profile there (float64 cue units); the whole raster with ``whole``."""
        cx, cy = self.position(t, arena_side)
        if whole:
            rows = cols = slice(0, cells)
        else:
            reach = self.radius / cell_size + 1
            rows = slice(max(0, math.floor(cy / cell_size - reach)),
                         min(cells, math.ceil(cy / cell_size + reach) + 1))
            cols = slice(max(0, math.floor(cx / cell_size - reach)),
                         min(cells, math.ceil(cx / cell_size + reach) + 1))
        ys = (np.arange(rows.start, rows.stop) + 0.5) * cell_size
        xs = (np.arange(cols.start, cols.stop) + 0.5) * cell_size
        profile = np.empty((len(ys), len(xs)))
        _profile(xs, ys, cx, cy, self.radius, self.peak, self.profile == 'gaussian', profile)
        return (rows, cols), profile


@numba.njit(cache=True)
def _profile(xs: np.ndarray, ys: np.ndarray, cx: float, cy: float, radius: float, peak: float,
             gaussian: bool, out: np.ndarray) -> None:  # pragma: no cover - jit
    """A source's profile (cue units) at the cell centres ``xs`` x ``ys`` into ``out``.

    Linear: peak * max(1 - d / radius, 0), the paper's disc, with the arithmetic of numpy's
    hypot, divide and clip (so the same bits as ever). Gaussian: peak * exp(-d^2 / 2 sigma^2)
    with sigma = radius / 3, 0 beyond the radius, taken as the product of its x and y factors
    (a few hundred exponentials per window instead of one per cell: a leaking source
    recomputes its window every transport tick).
    """
    if radius <= 0:
        out[:, :] = 0.0
        return
    if not gaussian:
        for i in range(ys.shape[0]):
            dy = ys[i] - cy
            for j in range(xs.shape[0]):
                out[i, j] = peak * max(1.0 - math.hypot(xs[j] - cx, dy) / radius, 0.0)
        return
    scale = -0.5 / (radius / GAUSSIAN_SIGMAS) ** 2
    gx = np.exp(scale * (xs - cx) ** 2)
    dx2 = (xs - cx) ** 2
    for i in range(ys.shape[0]):
        dy2 = (ys[i] - cy) ** 2
        gy = peak * math.exp(scale * dy2)
        for j in range(xs.shape[0]):
            out[i, j] = gy * gx[j] if dx2[j] + dy2 <= radius * radius else 0.0


def _reflect(coordinate: float, side: float) -> float:
    """A coordinate moving freely, folded back into [0, side] as if it bounced off walls."""
    period = 2.0 * side
    folded = math.fmod(coordinate, period)
    if folded < 0:
        folded += period
    return folded if folded <= side else period - folded


def _along_loop(points: tuple[tuple[float, float], ...], distance: float) -> tuple[float, float]:
    """The point ``distance`` (m) along the closed polyline through ``points``."""
    legs = [(a, b, math.dist(a, b)) for a, b in zip(points, points[1:] + points[:1])]
    perimeter = sum(length for _, _, length in legs)
    if perimeter == 0:
        return points[0]
    remaining = math.fmod(distance, perimeter)
    for (ax, ay), (bx, by), length in legs:
        if remaining <= length and length > 0:
            f = remaining / length
            return (ax + f * (bx - ax), ay + f * (by - ay))
        remaining -= length
    return points[0]


def load_cue_file(path: str, cells: int) -> np.ndarray:
    """A measured contamination map as the initial cue: float32 [cells, cells], 0..255.

    ``.npy``: a 2-D array in cue units with row = y cell (row 0 at y = 0, as the raster).
    An image (PNG, JPEG, ...): its grey level 0..255 is the cue, top row at the far (+y)
    wall, so the picture looks as it does on screen. Either is resampled to the raster by
    nearest cell, so it covers the whole arena.

    Raises:
        ParameterError: the file is missing, unreadable, neither a .npy array of numbers nor
            an image, not 2-D, or holds values outside 0..255.
    """
    file = Path(path)
    key = f'world.cue_file = {path!r}'
    if not file.is_file():
        raise ParameterError(f'{key}: ' + ('a folder, not a file' if file.is_dir() else
                                           'no such file') + ' (a path absolute or relative '
                             'to the parameter file naming it)')
    try:
        if file.suffix == '.npy':
            values = np.load(file, allow_pickle=False)
        else:
            from PIL import Image  # only for image files; pillow comes with matplotlib
            with Image.open(file) as image:
                values = np.asarray(image.convert('L'), dtype=np.float64)[::-1]
        values = np.asarray(values, dtype=np.float64)
    except OSError as error:  # PIL's UnidentifiedImageError is one
        reason = error.strerror or 'not an image (PNG, JPEG, ...)'
        raise ParameterError(f'{key}: cannot read it: {reason}; give a .npy array or an '
                             'image') from None
    except (ValueError, TypeError) as error:  # np.load of a damaged file, or not numbers
        raise ParameterError(f'{key}: not a .npy array of numbers ({error})') from None
    if values.ndim != 2 or min(values.shape) == 0:
        raise ParameterError(f'{key}: expected a 2-D map, got shape {values.shape}')
    if not np.all(np.isfinite(values)) or values.min() < 0 or values.max() > 255:
        raise ParameterError(f'{key}: values must lie in 0..255 (found '
                             f'{values.min():g}..{values.max():g}): scale the map to '
                             'cue units')
    rows = np.minimum((np.arange(cells) + 0.5) * values.shape[0] / cells, values.shape[0] - 1)
    cols = np.minimum((np.arange(cells) + 0.5) * values.shape[1] / cells, values.shape[1] - 1)
    cue: np.ndarray = values[rows.astype(np.int64)][:, cols.astype(np.int64)].astype(np.float32)
    return cue
