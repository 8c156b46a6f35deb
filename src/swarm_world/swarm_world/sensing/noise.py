"""Sensor and wheel noise from counter-based random streams, the same in both runners.

Each draw is a pure function of (episode seed, stream, robot id, step, index): a SplitMix64
hash of the five turned into a uniform double. So a robot's noise does not depend on how many
robots there are, in what order they are processed, or which process hosts the world, and a
step can be replayed without replaying the steps before it. The streams are numbered after
placement (0) and the controllers (1), which keep their numpy generators:

* :data:`GROUND_STREAM`: Gaussian noise of the ground sensors, in cue units, added before the
  reading is rounded to 0..255;
* :data:`IR_STREAM`: IR false negatives, a beam that sees something reports nothing;
* :data:`WHEEL_STREAM`: relative Gaussian error of each wheel's speed (slip).
"""

from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np

GROUND_STREAM, IR_STREAM, WHEEL_STREAM = 2, 3, 4

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_DOUBLE = 1.0 / 9007199254740992.0  # 2^-53


@numba.njit(cache=True)
def _mix(x: np.uint64) -> np.uint64:  # pragma: no cover - jitted
    """The SplitMix64 finaliser: a bijection of uint64 that scatters every input bit."""
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


@numba.njit(cache=True)
def _uniform(seed: int, stream: int, robot: int, step: int,
             index: int) -> float:  # pragma: no cover - jitted
    """A uniform double in [0, 1) for one key."""
    h = _mix(np.uint64(seed) + _GOLDEN)
    h = _mix(h ^ (np.uint64(stream) + _GOLDEN))
    h = _mix(h ^ (np.uint64(robot) + _GOLDEN))
    h = _mix(h ^ (np.uint64(step) + _GOLDEN))
    h = _mix(h ^ (np.uint64(index) + _GOLDEN))
    return float(h >> np.uint64(11)) * _DOUBLE


@numba.njit(cache=True)
def _fill_uniform(seed: int, stream: int, robots: np.ndarray, step: int,
                  out: np.ndarray) -> np.ndarray:  # pragma: no cover - jitted
    for i in range(out.shape[0]):
        for k in range(out.shape[1]):
            out[i, k] = _uniform(seed, stream, robots[i], step, k)
    return out


@numba.njit(cache=True)
def _fill_normal(seed: int, stream: int, robots: np.ndarray, step: int,
                 out: np.ndarray) -> np.ndarray:  # pragma: no cover - jitted
    """Standard normals by Box-Muller, each from the uniforms of indices 2k and 2k + 1."""
    for i in range(out.shape[0]):
        for k in range(out.shape[1]):
            u = _uniform(seed, stream, robots[i], step, 2 * k)
            v = _uniform(seed, stream, robots[i], step, 2 * k + 1)
            out[i, k] = math.sqrt(-2.0 * math.log(1.0 - u)) * math.cos(2.0 * math.pi * v)
    return out


def uniforms(seed: int, stream: int, robots: np.ndarray, step: int, count: int) -> np.ndarray:
    """[len(robots), count] uniforms in [0, 1) of (seed, stream, robot, step)."""
    out = np.empty((len(robots), count))
    return _fill_uniform(seed, stream, np.asarray(robots, dtype=np.int64), step, out)


def normals(seed: int, stream: int, robots: np.ndarray, step: int, count: int) -> np.ndarray:
    """[len(robots), count] standard normals of (seed, stream, robot, step)."""
    out = np.empty((len(robots), count))
    return _fill_normal(seed, stream, np.asarray(robots, dtype=np.int64), step, out)


@dataclasses.dataclass(frozen=True)
class NoiseLevels:
    """How noisy the sensors and wheels are (all zero: the noise-free model, bit for bit)."""

    ground: float = 0.0  #: standard deviation of the ground readings, cue units
    ir_miss: float = 0.0  #: probability that a beam seeing something reports nothing
    wheel: float = 0.0  #: relative standard deviation of each wheel's speed

    @property
    def any(self) -> bool:
        """Is any noise on?"""
        return bool(self.ground or self.ir_miss or self.wheel)


def noisy_wheels(linear: np.ndarray, angular: np.ndarray, separation: float, error: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(linear, angular) with each wheel's speed scaled by (1 + error) [N, 2] (left, right)."""
    left = (linear - angular * separation / 2) * (1.0 + error[:, 0])
    right = (linear + angular * separation / 2) * (1.0 + error[:, 1])
    return (left + right) / 2, (right - left) / separation
