"""Transport of the cue on its raster: diffusion, evaporation and emission, in sim time.

Diffusion is the explicit 5-point scheme written as fluxes between neighbouring cells, with no
flux through the walls: what leaves one cell enters its neighbour, so the total is conserved
to float rounding. It is split into substeps with D dt / h^2 <= :data:`STABLE_NUMBER` per axis
(the explicit scheme is stable and keeps the cue >= 0 up to 1/4 in 2-D), so any coefficient
and period are stable. Evaporation multiplies by 2^(-dt / half-life), exactly a half after
one half-life.
"""

from __future__ import annotations

import math

import numba
import numpy as np

#: Largest D dt / h^2 of one diffusion substep (stable and positive below 1/4 in 2-D).
STABLE_NUMBER = 0.2


def diffusion_substeps(diffusion: float, dt: float, cell_size: float) -> int:
    """How many explicit substeps keep one diffusion update of ``dt`` seconds stable."""
    number = diffusion * dt / cell_size**2
    return max(1, math.ceil(number / STABLE_NUMBER))


def diffuse(cue: np.ndarray, diffusion: float, dt: float, cell_size: float) -> np.ndarray:
    """``cue`` after diffusing for ``dt`` seconds (m^2/s, m); walls let nothing through.

    Computed in float64 and returned as a new array of the cue's dtype.
    """
    if diffusion <= 0 or dt <= 0:
        return cue
    substeps = diffusion_substeps(diffusion, dt, cell_size)
    number = diffusion * dt / substeps / cell_size**2
    field = cue.astype(np.float64)
    _diffuse_substeps(field, np.empty_like(field), number, substeps)
    return field.astype(cue.dtype)


@numba.njit(cache=True)
def _diffuse_substeps(field: np.ndarray, scratch: np.ndarray, number: float,
                      substeps: int) -> None:  # pragma: no cover - jit
    """``substeps`` explicit steps in place: each cell gains ``number`` times the difference
    to each neighbour inside the raster (pairwise fluxes: what one loses the other gains).

    Beyond a wall the "neighbour" is the cell itself, a difference of exactly 0: no flux, and
    the inner loop needs no branch (so the compiler vectorises it).
    """
    rows, cols = field.shape
    old, new = field, scratch
    for _ in range(substeps):
        for i in range(rows):
            up = i - 1 if i > 0 else i
            down = i + 1 if i < rows - 1 else i
            row, above, below, out = old[i], old[up], old[down], new[i]
            for j in (0, cols - 1):  # the side walls
                left, right = max(j - 1, 0), min(j + 1, cols - 1)
                here = row[j]
                flow = row[left] - here
                flow += row[right] - here
                flow += above[j] - here
                flow += below[j] - here
                out[j] = here + number * flow
            for j in range(1, cols - 1):  # no branch: the compiler vectorises this loop
                here = row[j]
                flow = row[j - 1] - here
                flow += row[j + 1] - here
                flow += above[j] - here
                flow += below[j] - here
                out[j] = here + number * flow
        old, new = new, old
    if substeps % 2:
        field[:, :] = old


def evaporation_factor(half_life: float, dt: float) -> float:
    """What remains of the cue after ``dt`` seconds (1 when ``half_life`` is 0: none)."""
    return 1.0 if half_life <= 0 else 2.0 ** (-dt / half_life)


def emit(cue: np.ndarray, profile: np.ndarray, rate: float, peak: float, dt: float) -> None:
    """A leaking source, in place: each cell of ``cue`` below ``profile`` (cue units, the
    same shape: pass matching windows) gains ``rate * dt`` scaled by the profile's shape
    (profile / peak), never rising above it."""
    if rate <= 0 or peak <= 0:
        return
    target = profile.astype(cue.dtype)
    below = cue < target
    gain = (profile[below] * (rate * dt / peak)).astype(cue.dtype)
    cue[below] = np.minimum(cue[below] + gain, target[below])
