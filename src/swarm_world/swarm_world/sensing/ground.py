"""The two ground sensors of a simulated Mona: what each reads of the cue under it.

Readings are produced in the form a real Mona (and the ROS messages) carry them: uint8
0..255. The kernel is compiled with numba: a plain loop over robots reads as the geometry it
implements and runs in microseconds, where the vectorised numpy version spent most of a step
on call overhead. Both runners use these functions (:mod:`swarm_world.reference` holds the
plain-Python reference of the IR ring; docs/model.md, "Sensors").
"""

from __future__ import annotations

import math
from typing import Any

import numba
import numpy as np

from mona_controller.mona import MonaParams
from swarm_world.sensing.headings import heading_trig
from swarm_world.sensing.params import SensingParams
from swarm_world.sensing.transfer import transfer_table

#: No ground noise: what :func:`ground_kernel` takes for ``noise`` when there is none.
NO_NOISE = np.zeros((0, 2))


@numba.njit(cache=True)
def ground_kernel(cue: np.ndarray, cell_size: float, poses: np.ndarray, trig: np.ndarray,
                  geometry: np.ndarray, table: np.ndarray, noise: np.ndarray,
                  out: np.ndarray) -> np.ndarray:  # pragma: no cover - jitted
    """The compiled core of :func:`ground_readings`, into ``out`` [N, 2] uint8.

    Args:
        cue: the sensed field (float32 [rows, cols]).
        cell_size: m per cell.
        poses: [N, 3] float64; trig: their :func:`heading_trig`.
        geometry: (half the distance between the sensors, how far ahead of the axle they
            sit) in m (:func:`sensor_geometry`).
        table: the transfer's readings at evenly spaced cue values
            (:func:`swarm_world.sensing.transfer.transfer_table`), or empty: the cell value itself.
        noise: [N, 2] reading units added before rounding, or :data:`NO_NOISE` (zero rows).
        out: [N, 2] uint8, filled and returned.
    """
    last = cue.shape[0] - 1
    noisy = noise.shape[0] > 0
    half_separation, offset = geometry[0], geometry[1]
    knots = table.shape[0]
    for i in range(poses.shape[0]):
        x, y = poses[i, 0], poses[i, 1]
        if offset != 0.0:  # ahead of the axle, along the heading
            x, y = x + trig[i, 0] * offset, y + trig[i, 1] * offset
        # The left sensor is at +y in the body frame (REP 103): offset (-sin, cos) * half.
        ox = -trig[i, 1] * half_separation
        oy = trig[i, 0] * half_separation
        for side in range(2):
            sign = 1.0 if side == 0 else -1.0
            col = min(max(math.floor((x + sign * ox) / cell_size), 0), last)
            row = min(max(math.floor((y + sign * oy) / cell_size), 0), last)
            value = cue[row, col]
            if knots:  # the transfer, linear between its knots
                at = min(max(value * (knots - 1) / 255.0, 0.0), knots - 1.0)
                below = min(int(at), knots - 2)
                value = table[below] + (at - below) * (table[below + 1] - table[below])
            if noisy:
                value = value + noise[i, side]
            out[i, side] = np.uint8(min(max(np.rint(value), 0.0), 255.0))
    return out


def sensor_geometry(mona: MonaParams, sensing: SensingParams) -> np.ndarray:
    """[half the distance between the two ground sensors, their offset ahead of the axle] (m):
    under the wheels unless ``sensing.ground_baseline`` says otherwise."""
    baseline = sensing.ground_baseline or mona.wheel_separation
    return np.array([baseline / 2, sensing.ground_offset])


def ground_readings(cue: np.ndarray, cell_size: float, poses: np.ndarray, mona: MonaParams,
                    sensing: SensingParams, noise: np.ndarray | None = None) -> np.ndarray:
    """What the left and right ground sensors read, rounded: [N, 2] uint8 (left, right).

    Args:
        cue: the field the sensors see (the cue, or its footprint's sensed field).
        mona, sensing: the robot's wheels; the sensors' geometry and transfer.
        noise: [N, 2] reading units added to each value before it is rounded and clipped to
            0..255 (sensor noise; None: none).
    """
    out = np.empty((len(poses), 2), dtype=np.uint8)
    noise = NO_NOISE if noise is None else np.ascontiguousarray(noise, dtype=np.float64)
    poses = np.ascontiguousarray(poses, dtype=np.float64)
    return ground_kernel(cue, cell_size, poses, heading_trig(poses),
                         sensor_geometry(mona, sensing), transfer_table(sensing), noise, out)


def field_list(fields: list[np.ndarray]) -> Any:
    """A typed list of ``fields`` (2-D float32 arrays, at least one) for
    :func:`ground_many_kernel`, built by cached kernels: ``numba.typed.List`` itself compiles
    its methods in every process (0.3 - 0.9 CPU-s, once per study worker and CLI run)."""
    typed = _field_list(fields[0])
    for field in fields[1:]:
        _append_field(typed, field)
    return typed


@numba.njit(cache=True)
def _field_list(first: np.ndarray) -> Any:  # pragma: no cover - jitted
    fields = numba.typed.List()
    fields.append(first)
    return fields


@numba.njit(cache=True)
def _append_field(fields: Any, field: np.ndarray) -> None:  # pragma: no cover - jitted
    fields.append(field)


@numba.njit(cache=True)
def set_field(fields: Any, e: int, field: np.ndarray) -> None:  # pragma: no cover - jitted
    """``fields[e] = field`` for a :func:`field_list`, without compiling in this process."""
    fields[e] = field


@numba.njit(cache=True)
def ground_many_kernel(fields: Any, bounds: np.ndarray, cell_size: np.ndarray,
                       geometry: np.ndarray, tables: np.ndarray, tabled: np.ndarray,
                       poses: np.ndarray, trig: np.ndarray, noise: np.ndarray,
                       noisy: np.ndarray, out: np.ndarray
                       ) -> np.ndarray:  # pragma: no cover - jitted
    """:func:`ground_kernel` for several arenas in one call (the batched engine).

    Args:
        fields: a typed list of each arena's sensed field.
        bounds: [E + 1] int64, arena e holds robots ``bounds[e]:bounds[e + 1]``.
        cell_size: [E] each arena's; geometry: [E, 2] each arena's :func:`sensor_geometry`.
        tables: [E, K] the transfer tables (K may be 0); tabled: [E] bool, arena e reads
            through its row (else the cell value itself).
        poses, trig: [R, 3] and [R, 2] every robot's, arena after arena.
        noise: [R, 2] reading units (rows of noisy arenas only are read), or
            :data:`NO_NOISE`.
        noisy: [E] bool, whether arena e adds its rows of ``noise``.
        out: [R, 2] uint8, filled and returned.
    """
    # Each arena's robots [bounds[e], bounds[e + 1]) on its own field, by the one-arena
    # kernel on their own rows: the same arithmetic, so the same readings, as alone.
    for e in range(bounds.shape[0] - 1):
        lo, hi = bounds[e], bounds[e + 1]
        ground_kernel(fields[e], cell_size[e], poses[lo:hi], trig[lo:hi], geometry[e],
                      tables[e] if tabled[e] else tables[e, :0],
                      noise[lo:hi] if noisy[e] else noise[lo:lo], out[lo:hi])
    return out
