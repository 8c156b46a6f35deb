"""The ``stand_net`` kind's step as one numba kernel (:mod:`mona_controller.stand_net`).

Explicit float64 loops in one fixed order, every sum starting at its bias and adding its
terms in index order, no BLAS and no ``fastmath``; softsign and the stand's probability are
exact IEEE arithmetic. So a robot computes the same bits alone, in a merged batch of any
size and in a controller node, and the same as :class:`mona_controller.stand_net.Longhand`.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def step_kernel(ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray, now: np.ndarray,
                deciding: np.ndarray, draws: np.ndarray, weights: np.ndarray,
                offset: np.ndarray, hidden: np.ndarray, ir_range: np.ndarray, top: np.ndarray,
                needs_robot: np.ndarray, standing: np.ndarray, began: np.ndarray,
                level0: np.ndarray, last_seen: np.ndarray, seen_since: np.ndarray,
                wheels: np.ndarray, cleaner: np.ndarray) -> None:  # pragma: no cover (compiled)
    """One control step of every robot.

    Robot i reads its net at ``weights[offset[i]:]`` (w1, b1, w2, b2 flattened) with
    ``hidden[i]`` neurons; ``ir_range[i]`` scales its beams, ``top[i]`` its wheels. Its
    on-board state (``standing``, ``began``, ``level0``, ``last_seen``, ``seen_since``) is
    updated in place; where ``deciding[i]`` it decides its stand with the draw ``draws[i]``
    (may it begin one without a robot seen since its last decision: not ``needs_robot[i]``).
    ``wheels`` [N, 2] and ``cleaner`` [N] are written.
    """
    n, k = ranges.shape
    width = 2 + 2 * k + 4
    base = 2 + 2 * k
    x = np.empty(width)
    h = np.empty(64)
    out = np.empty(3)
    for i in range(n):
        t = now[i]
        left = np.float64(ground[i, 0])
        right = np.float64(ground[i, 1])
        level = (left + right) * 0.5
        x[0] = level / 32.0
        x[1] = (left - right) / 32.0
        robot = False
        for b in range(k):
            r = np.float64(ranges[i, b])
            if r < np.inf:
                x[2 + b] = 1.0 - min(r / ir_range[i], 1.0)
                x[2 + k + b] = 1.0 if is_robot[i, b] else 0.0
                robot = robot or is_robot[i, b]
            else:
                x[2 + b] = 0.0
                x[2 + k + b] = 0.0
        if robot:
            last_seen[i] = t
            seen_since[i] = True
        if standing[i]:
            x[base] = 1.0
            x[base + 1] = (t - began[i]) / 10.0
            x[base + 3] = (level0[i] - level) / 32.0
        else:
            x[base] = 0.0
            x[base + 1] = 0.0
            x[base + 3] = 0.0
        x[base + 2] = 1.0 / (1.0 + (t - last_seen[i]) / 10.0)  # never seen: 1 / inf = 0
        m = hidden[i]
        w1 = offset[i]
        b1 = w1 + m * width
        w2 = b1 + m
        b2 = w2 + 3 * m
        for j in range(m):
            acc = weights[b1 + j]
            for c in range(width):
                acc += weights[w1 + j * width + c] * x[c]
            h[j] = acc / (1.0 + abs(acc))
        for o in range(3):
            acc = weights[b2 + o]
            for j in range(m):
                acc += weights[w2 + o * m + j] * h[j]
            out[o] = acc
        if deciding[i]:
            p = min(max(0.5 + out[2] * 0.25, 0.0), 1.0)
            may = standing[i] or seen_since[i] or not needs_robot[i]
            stand = may and draws[i] < p
            if stand and not standing[i]:
                began[i] = t
                level0[i] = level
            standing[i] = stand
            seen_since[i] = False
        cleaner[i] = standing[i]
        if standing[i]:
            wheels[i, 0] = 0.0
            wheels[i, 1] = 0.0
        else:
            wheels[i, 0] = out[0] / (1.0 + abs(out[0])) * top[i]
            wheels[i, 1] = out[1] / (1.0 + abs(out[1])) * top[i]
