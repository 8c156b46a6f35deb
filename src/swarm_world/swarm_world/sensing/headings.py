"""The cosine and sine of every robot's heading: the ground sensors
(:mod:`swarm_world.sensing.ground`), the IR ring (:mod:`swarm_world.sensing.ir`) and the
wheels' force (:mod:`swarm_world.physics`) all need them, and a batch works them out once per
step for all three."""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def heading_trig(poses: np.ndarray) -> np.ndarray:  # pragma: no cover - jitted
    """[N, 2]: each robot's (cos, sin) of its heading. The ground sensors, the IR ring and the
    wheels' force all need them; a batch works them out once per step for all three."""
    trig = np.empty((poses.shape[0], 2))
    for i in range(poses.shape[0]):
        trig[i, 0], trig[i, 1] = math.cos(poses[i, 2]), math.sin(poses[i, 2])
    return trig
