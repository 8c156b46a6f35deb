"""The ``network`` controller: a small neural net per robot, the same bits in any runner.

Each step a robot's readings become one input vector: its two ground sensors scaled to
[0, 1], each IR beam's proximity ``1 - min(range / ir_range, 1)`` (0 where nothing is seen),
each beam's robot flag (1 where the obstacle seen is a robot) and its own three previous
outputs. One hidden layer of ``controller.network.hidden`` softsign neurons (with
``recurrent``, also fed its own previous values: an Elman net) feeds three softsign outputs:
the left and right wheels (times the top wheel command: the Mona's, or the one of
``max_speed``, :func:`top_command`) and the cleaner (on where the output is > 0; with
``clean_stops`` a cleaning robot's wheels are commanded 0, so it cleans only standing, as a
waiting BEECLUST robot does).

The net's arrays, its genome and its weights file: :mod:`.network_weights`; the step, a
numba kernel held bit for bit to a plain-Python pass: :mod:`.network_forward` (imported on
the first step, so that the parameters and other kinds never import numba).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from mona_controller.controllers.base import Command, Controller, State
from mona_controller.controllers.network_weights import (
    MAX_HIDDEN,
    OUTPUTS,
    flatten,
    input_count,
    load_weights,
    shapes,
    weights_file,
)
from mona_controller.controllers.params import ControllerParams
from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError, param, validate

#: The stream id of seeded weights (controllers use 1, placement another).
NETWORK_STREAM = 7
#: Behaviour states: a robot whose cleaner is off moves (green), one cleaning red.
MOVING, CLEANING = 0, 1
STATES = (State('moving', (0.20, 0.75, 0.25, 1.0)), State('cleaning', (0.90, 0.10, 0.10, 1.0)))


@dataclasses.dataclass(frozen=True)
class NetworkParams:
    """The network kind's parameters, controller.network.* (docs/learned.md)."""

    hidden: int = param(8, unit='neurons', low=1, high=256,
                        doc='the hidden layer width (mona_controller.controllers.network)')
    recurrent: bool = param(False, doc='the hidden layer also reads its own previous values '
                                       '(an Elman net)')
    weights: str = param('', doc='the weights, an .npz (mona_controller.controllers.'
                                 'network_weights: w1, b1, w2, b2 and wr if recurrent); '
                                 'absolute, or relative to the parameter file naming it (to '
                                 "the current directory if given otherwise, e.g. -p); '' "
                                 'draws them from seed')
    seed: int = param(0, low=0, high=2**32 - 1,
                      doc='the seed of the weights when weights is empty (N(0, 1) each)')
    weights_sha256: str = param('', doc='the SHA-256 of weights, worked out on loading (a '
                                        "value given must match the file's)")
    max_speed: float = param(0.0, unit='m/s', low=0.0, high=1.0,
                             doc='the top wheel speed, forward or back (the wheel outputs are '
                                 "scaled to it, within mona.max_wheel_command); 0: the Mona's "
                                 'top command')
    clean_stops: bool = param(False, doc='clean only standing: where the cleaner output is '
                                         "on, both wheels are commanded 0 (as BEECLUST's "
                                         'robots clean only while they wait)')

    def __post_init__(self) -> None:
        validate(self, 'controller.network.')
        check_weights(self)


def check_weights(params: NetworkParams) -> None:
    """Resolve ``params.weights`` to an absolute path, fill in its SHA-256 and check its
    arrays fit the declared net (the inputs are checked with the Mona, by the controller).
    Called by ``NetworkParams`` on building.

    Raises:
        ParameterError: naming the key: a missing or bad file, a hash that does not match,
            an array missing, extra or of the wrong shape.
    """
    found = weights_file('network', params.weights, params.weights_sha256)
    if found is None:
        return
    key, path, digest, arrays = found
    hidden = params.hidden
    if hidden > MAX_HIDDEN:
        raise ParameterError(f'controller.network.hidden = {hidden}: at most {MAX_HIDDEN}')
    inputs = arrays['w1'].shape[1] if arrays.get('w1', np.zeros(0)).ndim == 2 else 0
    expected = shapes(inputs, hidden, params.recurrent)
    extra = sorted(arrays.keys() - expected.keys())
    if extra:
        raise ParameterError(f'{key}: holds {", ".join(extra)}, not part of a net with '
                             f'recurrent = {params.recurrent}')
    for name, shape in expected.items():
        if name not in arrays:
            raise ParameterError(f'{key}: lacks {name} (a net with recurrent = '
                                 f'{params.recurrent} needs {", ".join(expected)})')
        if arrays[name].shape != shape:
            raise ParameterError(f'{key}: {name} is {list(arrays[name].shape)}, a net of '
                                 f'hidden = {hidden} needs {list(shape)}')
    object.__setattr__(params, 'weights', path)
    object.__setattr__(params, 'weights_sha256', digest)


def net_weights(params: NetworkParams, mona: MonaParams) -> dict[str, np.ndarray]:
    """The arrays of ``params``' net for ``mona``: its file's, or drawn from its seed.

    Raises:
        ParameterError: the file's net has another number of inputs than ``mona`` gives.
    """
    inputs = input_count(mona.ir_count)
    if not params.weights:
        rng = np.random.default_rng([NETWORK_STREAM, params.seed])
        return {name: rng.normal(size=shape) for name, shape in
                shapes(inputs, params.hidden, params.recurrent).items()}
    arrays = load_weights(params.weights, params.weights_sha256)
    if arrays['w1'].shape[1] != inputs:
        raise ParameterError(f'controller.network.weights = {params.weights!r}: w1 has '
                             f'{arrays["w1"].shape[1]} inputs, a Mona with '
                             f'{mona.ir_count} IR sensors gives {inputs} (2 ground, '
                             f'{mona.ir_count} proximities, {mona.ir_count} robot flags, '
                             f'{OUTPUTS} previous outputs)')
    return arrays


def top_command(params: NetworkParams, mona: MonaParams) -> float:
    """The wheel command a net's wheel output of 1 stands for: ``mona.max_wheel_command``,
    or with ``max_speed`` > 0 that speed in wheel units (worked out as BEECLUST's beta is,
    ``speed / wheel_unit_speed``), within the Mona's top command."""
    if params.max_speed == 0.0:
        return float(mona.max_wheel_command)
    return min(params.max_speed / mona.wheel_unit_speed, mona.max_wheel_command)


class NetworkController(Controller):
    """The neural controllers of the robots ``robot_ids`` (the ``network`` kind).

    ``state`` is :data:`CLEANING` while a robot's cleaner is on and :data:`MOVING` otherwise,
    for observers; ``encounters`` stays 0 (a net counts no meetings). A merged controller
    holds every part's net in one vector and each robot's offset into it (:meth:`derive`).
    """

    STATES = STATES
    Params = NetworkParams
    PER_ROBOT = (*Controller.PER_ROBOT, 'previous', 'context')

    def __init__(self, params: ControllerParams, mona: MonaParams,
                 robot_ids: Sequence[int]) -> None:
        """The robots ``robot_ids``, reset (outputs and hidden values zero).

        Raises:
            ParameterError: the weights do not fit ``mona``'s sensors.
        """
        super().__init__(params, mona, robot_ids)
        n = len(self.robot_ids)
        self.previous = np.zeros((n, OUTPUTS))
        self.context = np.zeros((n, MAX_HIDDEN))
        self.reset(0)

    def derive(self) -> None:
        """Every parameter set's net in one vector, and each robot's offset into it, width,
        recurrence, IR range, top wheel command (:func:`top_command`) and stopping."""
        nets = [params.section(NetworkParams) for params in self.params]
        flat = [flatten(net_weights(net, mona)) for net, mona in zip(nets, self.mona)]
        starts = np.cumsum([0] + [len(weights) for weights in flat[:-1]])
        self._weights = np.concatenate(flat)
        index = self.param_index
        self._offset = starts.astype(np.int64)[index]
        self._hidden = np.array([net.hidden for net in nets], np.int64)[index]
        self._recurrent = np.array([net.recurrent for net in nets], bool)[index]
        self._ir_range = np.array([m.ir_range for m in self.mona], np.float64)[index]
        self._top = np.array([top_command(net, m) for net, m in zip(nets, self.mona)],
                             np.float64)[index]
        self._stops = np.array([net.clean_stops for net in nets], bool)[index]

    def reset(self, seed: int) -> None:
        """Start a new episode: zero outputs and hidden values (a net draws no random
        numbers, so ``seed`` changes nothing)."""
        self.previous[:] = 0.0
        self.context[:] = 0.0
        self.state[:] = MOVING
        self.encounters[:] = 0

    def step(self, ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray,
             now: float | np.ndarray) -> Command:
        """Every robot's net on its readings: wheels and cleaner (``now`` is not read)."""
        from mona_controller.controllers.network_forward import forward  # numba: on first use

        n = len(self.robot_ids)
        wheels = np.empty((n, 2))
        cleaner = np.empty(n, dtype=bool)
        forward(np.asarray(ground, dtype=np.uint8), np.asarray(ranges, dtype=np.float32),
                np.asarray(is_robot, dtype=bool), self._weights, self._offset, self._hidden,
                self._recurrent, self._ir_range, self._top, self._stops, self.previous,
                self.context, wheels, cleaner)
        np.multiply(cleaner, CLEANING, out=self.state, casting='unsafe')
        return Command(wheels=wheels, cleaner=cleaner)
