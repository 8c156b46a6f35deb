"""One step of the network kind's net, as a compiled kernel and in plain Python.

:func:`forward` is a numba kernel of explicit float64 loops in one fixed order (no BLAS, no
fastmath), and softsign, ``x / (1 + |x|)``, is exact IEEE arithmetic: a robot computes the
same bits alone, in a merged batch of any size, and in a controller node.
:func:`reference_forward` is the same pass in plain Python, to check the kernel against
(tests/unit/test_network.py). Apart from :mod:`.network` so that building the parameters
(or a node that runs another kind) does not import numba.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def _softsign(x: float) -> float:
    return x / (1.0 + abs(x))


@numba.njit(cache=True, nogil=True)
def forward(ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray, weights: np.ndarray,
            offset: np.ndarray, hidden: np.ndarray, recurrent: np.ndarray,
            ir_range: np.ndarray, top: np.ndarray, stops: np.ndarray, previous: np.ndarray,
            context: np.ndarray, wheels: np.ndarray,
            cleaner: np.ndarray) -> None:  # pragma: no cover (compiled)
    """One step of every robot's net (the kernel; :func:`reference_forward` in Python).

    Robot i reads its net at ``weights[offset[i]:]`` (:func:`flatten`'s layout), with
    ``hidden[i]`` neurons, recurrent or not; ``ir_range[i]`` scales its beams, ``top[i]``
    its wheels; where ``stops[i]``, a cleaning robot's wheels are 0. ``previous`` [N, 3] and
    ``context`` [N, MAX_HIDDEN] are its last outputs and hidden values, updated in place;
    ``wheels`` [N, 2] and ``cleaner`` [N] are written.
    Every sum starts at the bias and adds its terms in index order.
    """
    n, k = ranges.shape
    width = 2 + 2 * k + 3
    x = np.empty(width)
    h = np.empty(context.shape[1])
    for i in range(n):
        x[0] = ground[i, 0] / 255.0
        x[1] = ground[i, 1] / 255.0
        for b in range(k):
            r = np.float64(ranges[i, b])
            if r < np.inf:
                x[2 + b] = 1.0 - min(r / ir_range[i], 1.0)
                x[2 + k + b] = 1.0 if is_robot[i, b] else 0.0
            else:
                x[2 + b] = 0.0
                x[2 + k + b] = 0.0
        for o in range(3):
            x[2 + 2 * k + o] = previous[i, o]
        m = hidden[i]
        w1 = offset[i]
        b1 = w1 + m * width
        wr = b1 + m
        w2 = wr + (m * m if recurrent[i] else 0)
        b2 = w2 + 3 * m
        for j in range(m):
            acc = weights[b1 + j]
            for c in range(width):
                acc += weights[w1 + j * width + c] * x[c]
            if recurrent[i]:
                for c in range(m):
                    acc += weights[wr + j * m + c] * context[i, c]
            h[j] = _softsign(acc)
        for o in range(3):
            acc = weights[b2 + o]
            for j in range(m):
                acc += weights[w2 + o * m + j] * h[j]
            previous[i, o] = _softsign(acc)
        for j in range(m):
            context[i, j] = h[j]
        cleaner[i] = previous[i, 2] > 0.0
        if stops[i] and cleaner[i]:
            wheels[i, 0] = 0.0
            wheels[i, 1] = 0.0
        else:
            wheels[i, 0] = previous[i, 0] * top[i]
            wheels[i, 1] = previous[i, 1] * top[i]


def reference_forward(ground: Sequence[int], ranges: Sequence[float],
                      is_robot: Sequence[bool], arrays: Mapping[str, np.ndarray],
                      ir_range: float, top: float, previous: list[float],
                      context: list[float], stops: bool = False) -> tuple[float, float, bool]:
    """One robot's step of its net in plain Python floats (what :func:`forward` computes):
    its wheels and cleaner (with ``stops``, no wheels while cleaning); ``previous`` and
    ``context`` (its hidden values) are updated."""
    x = [ground[0] / 255.0, ground[1] / 255.0]
    seen = [float(r) < math.inf for r in ranges]
    x += [1.0 - min(float(r) / ir_range, 1.0) if s else 0.0 for r, s in zip(ranges, seen)]
    x += [1.0 if s and bool(flag) else 0.0 for flag, s in zip(is_robot, seen)]
    x += previous
    w1, b1, w2, b2 = (arrays[name].tolist() for name in ('w1', 'b1', 'w2', 'b2'))
    wr = arrays['wr'].tolist() if 'wr' in arrays else None
    h = []
    for j, row in enumerate(w1):
        acc = b1[j]
        for weight, value in zip(row, x):
            acc += weight * value
        if wr is not None:
            for weight, value in zip(wr[j], context):
                acc += weight * value
        h.append(acc / (1.0 + abs(acc)))
    for o, row in enumerate(w2):
        acc = b2[o]
        for weight, value in zip(row, h):
            acc += weight * value
        previous[o] = acc / (1.0 + abs(acc))
    context[:len(h)] = h
    clean = previous[2] > 0.0
    if stops and clean:
        return 0.0, 0.0, True
    return previous[0] * top, previous[1] * top, clean
