"""The cue (contamination) raster: cleaning it (eq. 3) and what the ground sensors read.

The initial field and its sources are :mod:`swarm_world.field` and :mod:`swarm_world.sources`.

The raster is float32 [rows, cols] with row = y cell and col = x cell, so cell (0, 0) is the
corner at the world origin (as in nav_msgs/OccupancyGrid).
"""

from __future__ import annotations

import math

import numba
import numpy as np


def cleaning_kernel(radius: int, peak: float) -> np.ndarray:
    """Eq. 3's patch: the cell at offset (p, q) loses peak - sqrt(p^2 + q^2), never < 0."""
    offsets = np.arange(-radius, radius + 1)
    amount = peak - np.hypot(offsets[None, :], offsets[:, None])
    return np.clip(amount, 0.0, None).astype(np.float32)


def cell_index(xy: np.ndarray, cell_size: float, cells: int) -> np.ndarray:
    """Integer (col, row) of the cells under points [N, 2] (m), clipped to the raster."""
    return np.clip(np.floor(xy / cell_size).astype(np.int64), 0, cells - 1)


#: How a cleaning tick changes a cell (``world.cleaning``), as the compiled kernel numbers them.
MONOTONE, LITERAL, BLEND = 0, 1, 2


def clean(cue: np.ndarray, cells: np.ndarray, kernel: np.ndarray, *,
          literal_levels: np.ndarray | None = None, blend: bool = False) -> None:
    """Apply eq. 3 in place for each robot cell (col, row) in ``cells`` [M, 2], in order.

    Monotone (default): each cell loses the kernel amount, floored at 0. Literal: each cell
    becomes the robot's mean sensor reading (``literal_levels`` [M]) minus the amount, floored
    at 0, as the paper writes it (this can raise cells cleaner than the reading). Blend: each
    cell is blended towards 0 as a Webots Display draws black with opacity amount / 255: in
    8-bit integers, the opacity truncated to floor(amount) and the value to
    floor((255 - opacity) x value / 255), so a cell loses a share of what it holds.
    """
    literal = literal_levels is not None
    levels = (np.asarray(literal_levels, dtype=np.float64) if literal
              else np.zeros(len(cells)))
    mode = LITERAL if literal else BLEND if blend else MONOTONE
    _clean_kernel(cue, np.asarray(cells, dtype=np.int64).reshape(-1, 2), kernel, levels, mode)


@numba.njit(cache=True)
def _clean_kernel(cue: np.ndarray, cells: np.ndarray, kernel: np.ndarray, levels: np.ndarray,
                  mode: int) -> None:  # pragma: no cover - jit
    # Cell by cell what numpy's maximum(base - patch, 0.0) does on each robot's window (the
    # same float32 subtraction, and maximum's "a >= b ? a : b"), robot after robot: the same
    # bits, without a dozen array operations per robot.
    radius = kernel.shape[0] // 2
    rows, cols = cue.shape
    for k in range(cells.shape[0]):
        col, row = cells[k, 0], cells[k, 1]
        level = np.float32(levels[k])
        for r in range(max(row - radius, 0), min(row + radius + 1, rows)):
            for c in range(max(col - radius, 0), min(col + radius + 1, cols)):
                amount = kernel[r - row + radius, c - col + radius]
                if mode == BLEND:
                    opacity = math.floor(amount)
                    cue[r, c] = math.floor((255 - opacity) * math.floor(cue[r, c]) / 255)
                    continue
                base = level if mode == LITERAL else cue[r, c]
                value = base - amount
                cue[r, c] = value if value >= 0.0 else 0.0


def footprint_cells(footprint: float, cell_size: float) -> int:
    """The half-width in cells of a ground sensor's square footprint of side ``footprint``
    (m): 0 reads one cell, 1 the mean of 3 x 3 cells, and so on."""
    return max(0, int(round((footprint / cell_size - 1) / 2)))


def sensed_field(cue: np.ndarray, half_width: int) -> np.ndarray:
    """What a ground sensor with a square footprint reads at each cell: the mean of the
    (2 * half_width + 1)^2 cells around it that lie in the arena (``cue`` itself for 0)."""
    if half_width == 0:
        return cue
    size = cue.shape[0]
    # Box sums from a zero-padded 2-D cumulative sum: O(cells) whatever the footprint.
    summed = np.zeros((size + 1, size + 1))
    summed[1:, 1:] = cue.astype(np.float64).cumsum(axis=0).cumsum(axis=1)
    low = np.clip(np.arange(size) - half_width, 0, size)
    high = np.clip(np.arange(size) + half_width + 1, 0, size)
    box = (summed[high][:, high] - summed[low][:, high] - summed[high][:, low]
           + summed[low][:, low])
    counts = np.outer(high - low, high - low)
    return (box / counts).astype(cue.dtype)
