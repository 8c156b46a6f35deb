"""Cleaning that needs company: which waiting robots clean at a cleaning tick.

In the paper's model (eq. 3) every robot whose cleaner is on cleans its own patch, whatever is
around it. Some tasks need several robots at once: a heavy or viscous spill that one robot
cannot lift, a valve two must turn, debris too large for one. With ``world.cleaning_quorum``
k > 1 a robot cleans at a tick only if at least k - 1 *other* robots whose cleaners are on
are within ``world.cleaning_range`` r of it (centre to centre): a group of k working
together. k = 1 is the paper's model (every cleaning robot cleans; this module is not
called), so every output is the paper's, bit for bit.

The test is exact and the same in every runner: squared distances of the world's float64
poses compared with r^2, counted pair by pair (an integer per robot), so the world node, the
embedded runner and any batch pick the same robots.
"""

from __future__ import annotations

import numba
import numpy as np


def in_company(cleaners: np.ndarray, poses: np.ndarray, quorum: int,
               radius: float) -> np.ndarray:
    """The robots of ``cleaners`` (indices in id order, their cleaners on) with at least
    ``quorum - 1`` others of ``cleaners`` within ``radius`` (m) of them, in id order.

    Args:
        cleaners: [M] int64 indices of the robots whose cleaners are on, ascending.
        poses: [N, 3] every robot's pose (x m, y m, heading rad).
        quorum: k, the robots a cleaning group needs (>= 1).
        radius: r (m), how close the others must be (centre to centre).
    """
    cleaners = np.asarray(cleaners, dtype=np.int64)
    if quorum <= 1 or len(cleaners) == 0:
        return cleaners
    xy = np.ascontiguousarray(poses[cleaners, :2], dtype=np.float64)
    company = np.zeros(len(cleaners), dtype=np.int64)
    _count_neighbours(xy, np.argsort(xy[:, 0], kind='stable'), radius, company)
    return cleaners[company >= quorum - 1]


@numba.njit(cache=True, nogil=True)
def _count_neighbours(xy: np.ndarray, order: np.ndarray, radius: float,
                      company: np.ndarray) -> None:  # pragma: no cover - compiled
    # A sweep along x: each robot is compared only with those after it in x within radius,
    # and a pair within radius counts for both. Integer counts: no rounding to differ.
    r2 = radius * radius
    m = len(order)
    for a in range(m):
        i = order[a]
        for b in range(a + 1, m):
            j = order[b]
            dx = xy[j, 0] - xy[i, 0]
            if dx > radius:
                break
            dy = xy[j, 1] - xy[i, 1]
            if dx * dx + dy * dy <= r2:
                company[i] += 1
                company[j] += 1
