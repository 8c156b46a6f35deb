"""The ``stand_net`` controller: a small net that drives, and at each cleaning tick decides,
with a draw from the robot's own generator, whether to stand and clean.

What a robot reads each control step (2 + 2K + 4 inputs, each of order 1, so that the
thresholds a stop rule needs lie within reach of weights of order 1):

- its ground readings: their mean S over 32 (the disc's peak, 255, is about 8) and their
  difference s_l - s_r over 32 (eq. 2's alpha = 2 turns a difference of 12 into a full
  6-unit wheel difference: 0.375 here);
- each IR beam's proximity ``1 - min(range / ir_range, 1)`` (0 where nothing is seen) and
  robot flag (1 where the obstacle seen is a robot);
- what it keeps on board: whether it stands (1 or 0), how long it has stood (s / 10), how
  recently it saw a robot, ``1 / (1 + t / 10 s)`` with t the seconds since a beam last saw
  one (1 now, 0 never), and how much its own reading fell since the stand began,
  (S at the start - S now) / 32 (0 while moving): how much it is cleaning.

One hidden layer of ``controller.stand_net.hidden`` softsign neurons feeds three outputs:
the wheels (softsign, times the top command of ``max_speed``, as the ``network`` kind's) and
the stand's logit a. A stand is decided only when a new ``period`` begins (the world's
``cleaning_period``: the first control step at or after each whole period), not every step:
the robot draws u ~ U[0, 1) from ``default_rng([seed, CONTROLLER_STREAM, robot id])`` and
stands for the period if u < p(a) = min(max(1/2 + a/4, 0), 1) (the logistic's slope at 0,
cut to [0, 1]: exact IEEE arithmetic, no library ``exp``). A standing robot's wheels are 0
and its cleaner on, so it cleans exactly at the ticks it stands through and never while
moving: BEECLUST's limits, with wheels at most ``max_speed``. With ``needs_robot`` a robot
may *begin* a stand only if a beam saw a robot since its last decision (BEECLUST's rule);
it may go on standing without one.

The step is one numba kernel (:mod:`.stand_net_forward`, imported on the first step), so a
robot computes the same bits alone, in any batch and in a controller node; :class:`Longhand`
is one robot's step in plain Python, to check the kernel against. The weights file is the
``network`` kind's format (:mod:`.network_weights`: w1 [hidden, inputs], b1, w2 [3, hidden],
b2), with 2 + 2K + 4 inputs; with ``weights: ''`` they are drawn from ``seed``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from mona_controller.controllers.base import Command, Controller, State
from mona_controller.controllers.beeclust import CONTROLLER_STREAM
from mona_controller.controllers.network_weights import (
    MAX_HIDDEN,
    cut_genome,
    flatten,
    load_weights,
    shapes,
    weights_file,
)
from mona_controller.controllers.params import ControllerParams
from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError, param, validate

#: The inputs beyond the ground's and the beams': standing, stood, recency, removed.
ON_BOARD = 4
#: Cue units and seconds per input unit.
CUE_SCALE, TIME_SCALE = 32.0, 10.0
#: The stream of seeded weights (the network kind's is 7).
STAND_NET_STREAM = 8
#: Behaviour states: moving (green), standing and cleaning (red).
MOVING, STANDING = 0, 1
STATES = (State('moving', (0.20, 0.75, 0.25, 1.0)), State('standing', (0.90, 0.10, 0.10, 1.0)))


@dataclasses.dataclass(frozen=True)
class StandNetParams:
    """The stand_net kind's parameters, ``controller.stand_net.*`` (docs/learned.md)."""

    hidden: int = param(6, unit='neurons', low=1, high=MAX_HIDDEN,
                        doc='the hidden layer width (mona_controller.controllers.stand_net)')
    weights: str = param('', doc="the weights, an .npz in the network kind's format (w1, b1, "
                                 'w2, b2); absolute, or relative to the parameter file naming '
                                 "it (to the current directory if given otherwise); '' draws "
                                 'them from seed')
    seed: int = param(0, low=0, high=2**32 - 1,
                      doc='the seed of the weights when weights is empty (N(0, 1) each)')
    weights_sha256: str = param('', doc='the SHA-256 of weights, worked out on loading (a '
                                        "value given must match the file's)")
    max_speed: float = param(0.08, unit='m/s', low=0.0, high=1.0,
                             doc="the top wheel speed, forward or back (BEECLUST's 8 cm/s; "
                                 "0: the Mona's top command)")
    period: float = param(1.0, unit='s', low=0.001, high=3600.0,
                          doc="seconds between two decisions to stand (the world's "
                              'cleaning_period)')
    needs_robot: bool = param(False, doc='begin a stand only with a robot seen since the last '
                                         "decision (BEECLUST's rule)")

    def __post_init__(self) -> None:
        validate(self, 'controller.stand_net.')
        check_weights(self)


def check_weights(params: StandNetParams) -> None:
    """Resolve ``params.weights`` to an absolute path, fill in its SHA-256 and check its
    arrays are a net of ``hidden`` neurons (the inputs are checked with the Mona, by the
    controller).

    Raises:
        ParameterError: naming the key: a missing or bad file, a hash that does not match,
            an array missing, extra or of the wrong shape.
    """
    found = weights_file('stand_net', params.weights, params.weights_sha256)
    if found is None:
        return
    key, path, digest, arrays = found
    inputs = arrays['w1'].shape[1] if arrays.get('w1', np.zeros(0)).ndim == 2 else 0
    expected = shapes(inputs, params.hidden, False)
    if set(arrays) != set(expected) or any(arrays[name].shape != shape
                                           for name, shape in expected.items()):
        raise ParameterError(f'{key}: holds {", ".join(sorted(arrays))} of shapes '
                             f'{[list(a.shape) for a in arrays.values()]}, not a net of hidden '
                             f'= {params.hidden} (w1, b1, w2, b2)')
    object.__setattr__(params, 'weights', path)
    object.__setattr__(params, 'weights_sha256', digest)


def top_command(params: StandNetParams, mona: MonaParams) -> float:
    """The wheel command a wheel output of 1 stands for: ``max_speed`` in wheel units (as
    BEECLUST's beta is worked out), within the Mona's top command; 0: the top command."""
    if params.max_speed == 0.0:
        return float(mona.max_wheel_command)
    return min(params.max_speed / mona.wheel_unit_speed, mona.max_wheel_command)


def input_count(ir_count: int) -> int:
    """The net's inputs: 2 ground, ``ir_count`` proximities and robot flags, 4 on board."""
    return 2 + 2 * ir_count + ON_BOARD


def genome_size(ir_count: int, hidden: int) -> int:
    """The number of weights of a net (the length of its genome)."""
    return sum(math.prod(shape) for shape in
               shapes(input_count(ir_count), hidden, False).values())


def weights_from_genome(genome: Sequence[float] | np.ndarray, ir_count: int,
                        hidden: int) -> dict[str, np.ndarray]:
    """Cut a flat genome into the net's arrays (w1, b1, w2, b2).

    Raises:
        ValueError: the genome has the wrong length.
    """
    return cut_genome(genome, shapes(input_count(ir_count), hidden, False))


def stand_probability(logit: float) -> float:
    """p(a) = min(max(1/2 + a/4, 0), 1): the chance of standing for the next period."""
    return min(max(0.5 + logit * 0.25, 0.0), 1.0)


def net_arrays(params: StandNetParams, mona: MonaParams) -> dict[str, np.ndarray]:
    """The arrays of ``params``' net for ``mona``: its file's, or drawn from its seed.

    Raises:
        ParameterError: the file's net has other inputs than ``mona`` gives.
    """
    inputs = input_count(mona.ir_count)
    if not params.weights:
        rng = np.random.default_rng([STAND_NET_STREAM, params.seed])
        return {name: rng.normal(size=shape) for name, shape in
                shapes(inputs, params.hidden, False).items()}
    arrays = load_weights(params.weights, params.weights_sha256)
    if arrays['w1'].shape[1] != inputs:
        raise ParameterError(f'controller.stand_net.weights = {params.weights!r}: w1 has '
                             f'{arrays["w1"].shape[1]} inputs, a stand_net on a Mona with '
                             f'{mona.ir_count} IR sensors reads {inputs} (2 ground, '
                             f'{mona.ir_count} proximities, {mona.ir_count} robot flags, '
                             f'{ON_BOARD} on board)')
    return arrays


class Longhand:
    """One robot's stand_net step in plain Python floats (what the kernel computes)."""

    def __init__(self, arrays: Mapping[str, np.ndarray], ir_range: float, top: float,
                 robot_id: int, seed: int, needs_robot: bool = False,
                 period: float = 1.0) -> None:
        self.w1, self.b1, self.w2, self.b2 = (arrays[name].tolist()
                                              for name in ('w1', 'b1', 'w2', 'b2'))
        self.ir_range, self.top, self.needs_robot, self.period = (ir_range, top,
                                                                  needs_robot, period)
        self.standing, self.began, self.level0 = False, 0.0, 0.0
        self.last_seen, self.seen_since, self.decided = -math.inf, False, -1
        self.rng = np.random.default_rng([seed, CONTROLLER_STREAM, robot_id])

    def step(self, ground: Sequence[int], ranges: Sequence[float], is_robot: Sequence[bool],
             now: float) -> tuple[tuple[float, float], bool]:
        """The wheels and the cleaner for these readings at ``now`` (s)."""
        left, right = float(ground[0]), float(ground[1])
        level = (left + right) * 0.5
        seen = [float(r) < math.inf for r in ranges]
        x = [level / CUE_SCALE, (left - right) / CUE_SCALE]
        x += [1.0 - min(float(r) / self.ir_range, 1.0) if s else 0.0
              for r, s in zip(ranges, seen)]
        flags = [1.0 if s and bool(f) else 0.0 for f, s in zip(is_robot, seen)]
        x += flags
        if any(flags):
            self.last_seen, self.seen_since = now, True
        stood = (now - self.began) / TIME_SCALE if self.standing else 0.0
        removed = (self.level0 - level) / CUE_SCALE if self.standing else 0.0
        x += [1.0 if self.standing else 0.0, stood,
              1.0 / (1.0 + (now - self.last_seen) / TIME_SCALE), removed]
        hidden = []
        for row, bias in zip(self.w1, self.b1):
            acc = bias
            for weight, value in zip(row, x):
                acc += weight * value
            hidden.append(acc / (1.0 + abs(acc)))
        out = []
        for row, bias in zip(self.w2, self.b2):
            acc = bias
            for weight, value in zip(row, hidden):
                acc += weight * value
            out.append(acc)
        period = math.floor(now / self.period)
        if period > self.decided:  # a new cleaning period: decide the stand
            self.decided = period
            draw = self.rng.random()
            may = self.standing or self.seen_since or not self.needs_robot
            stand = may and draw < stand_probability(out[2])
            if stand and not self.standing:
                self.began, self.level0 = now, level
            self.standing, self.seen_since = stand, False
        if self.standing:
            return (0.0, 0.0), True
        return (out[0] / (1.0 + abs(out[0])) * self.top,
                out[1] / (1.0 + abs(out[1])) * self.top), False


class StandNetController(Controller):
    """The stand_net controllers of the robots ``robot_ids`` (the ``stand_net`` kind).

    ``state`` is :data:`STANDING` while a robot stands (cleaning) and :data:`MOVING`
    otherwise; ``encounters`` stays 0. A merged controller holds every part's net in one
    vector and each robot's offset into it (:meth:`derive`).
    """

    STATES = STATES
    Params = StandNetParams
    PER_ROBOT = (*Controller.PER_ROBOT, 'standing', 'began', 'level0', 'last_seen',
                 'seen_since', 'decided', 'rngs')

    def __init__(self, params: ControllerParams, mona: MonaParams,
                 robot_ids: Sequence[int]) -> None:
        """The robots ``robot_ids``, reset with seed 0.

        Raises:
            ParameterError: no weights, or weights that do not fit ``mona``'s sensors.
        """
        super().__init__(params, mona, robot_ids)
        n = len(self.robot_ids)
        self.standing = np.zeros(n, dtype=bool)
        self.began = np.zeros(n)
        self.level0 = np.zeros(n)
        self.last_seen = np.zeros(n)
        self.seen_since = np.zeros(n, dtype=bool)
        self.decided = np.zeros(n, dtype=np.int64)
        self.rngs: list[np.random.Generator] = []
        self.reset(0)

    def derive(self) -> None:
        """Every parameter set's net in one vector, and each robot's offset into it, width,
        IR range, top wheel command and decision period."""
        own = [params.section(StandNetParams) for params in self.params]
        nets = [flatten(net_arrays(net, mona)) for net, mona in zip(own, self.mona)]
        starts = np.cumsum([0] + [len(net) for net in nets[:-1]])
        self._weights = np.concatenate(nets)
        index = self.param_index
        self._offset = starts.astype(np.int64)[index]
        self._hidden = np.array([net.hidden for net in own], np.int64)[index]
        self._ir_range = np.array([m.ir_range for m in self.mona], np.float64)[index]
        self._top = np.array([top_command(net, m) for net, m in zip(own, self.mona)],
                             np.float64)[index]
        self._needs_robot = np.array([net.needs_robot for net in own], bool)[index]
        self._period = np.array([net.period for net in own], np.float64)[index]

    def reset(self, seed: int) -> None:
        """Start a new episode: every robot moving, nothing seen, generators reseeded (the
        first decision is at time 0)."""
        self.standing[:] = False
        self.began[:] = 0.0
        self.level0[:] = 0.0
        self.last_seen[:] = -np.inf
        self.seen_since[:] = False
        self.decided[:] = -1
        self.state[:] = MOVING
        self.encounters[:] = 0
        self.rngs = [np.random.default_rng([seed, CONTROLLER_STREAM, int(i)])
                     for i in self.robot_ids]

    def step(self, ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray,
             now: float | np.ndarray) -> Command:
        """Every robot's net on its readings: wheels and cleaner; a stand decided at the
        first step of each period, with one draw from the robot's generator."""
        from mona_controller.controllers.stand_net_forward import step_kernel  # numba: lazily

        n = len(self.robot_ids)
        times = np.broadcast_to(np.asarray(now, dtype=np.float64), (n,))
        periods = np.floor(times / self._period).astype(np.int64)
        deciding = periods > self.decided
        draws = np.zeros(n)
        for i in np.flatnonzero(deciding).tolist():  # once a period: a few draws
            draws[i] = self.rngs[i].random()
        self.decided[deciding] = periods[deciding]
        wheels = np.empty((n, 2))
        cleaner = np.empty(n, dtype=bool)
        step_kernel(np.asarray(ground, dtype=np.uint8), np.asarray(ranges, dtype=np.float32),
                    np.asarray(is_robot, dtype=bool), np.ascontiguousarray(times), deciding,
                    draws, self._weights, self._offset, self._hidden, self._ir_range,
                    self._top, self._needs_robot, self.standing, self.began, self.level0,
                    self.last_seen, self.seen_since, wheels, cleaner)
        np.multiply(self.standing, STANDING, out=self.state, casting='unsafe')
        return Command(wheels=wheels, cleaner=cleaner)

