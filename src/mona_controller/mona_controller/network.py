"""The ``network`` controller: a small neural net per robot, the same bits in any runner.

Each step a robot's readings become one input vector (:func:`inputs_of`): its two ground
sensors scaled to [0, 1], each IR beam's proximity ``1 - min(range / ir_range, 1)`` (0 where
nothing is seen), each beam's robot flag (1 where the obstacle seen is a robot) and its own
three previous outputs. One hidden layer of ``network_hidden`` softsign neurons (with
``network_recurrent``, also fed its own previous values: an Elman net) feeds three softsign
outputs: the left and right wheels (times the top wheel command: the Mona's, or the one of
``network_max_speed``, :func:`top_command`) and the cleaner (on where the output is > 0; with
``network_clean_stops`` a cleaning robot's wheels are commanded 0, so it cleans only standing,
as a waiting BEECLUST robot does).

The forward pass is a numba kernel of explicit float64 loops in one fixed order (no BLAS,
no fastmath) and softsign, ``x / (1 + |x|)``, is exact IEEE arithmetic: a robot computes the
same bits alone, in a merged batch of any size, and in a controller node.
:func:`reference_forward` is the same pass in plain Python, to check the kernel against.

The weights file (``controller.network_weights``) is an ``.npz`` of float64 arrays: ``w1``
[hidden, inputs], ``b1`` [hidden], ``w2`` [3, hidden], ``b2`` [3] and, if recurrent, ``wr``
[hidden, hidden]. :func:`save_weights` writes one byte for byte the same for the same
weights (fixed zip timestamps); :func:`genome_size` and :func:`weights_from_genome` map a
flat genome (neuroevolution) to them.
"""

from __future__ import annotations

import functools
import hashlib
import io
import math
import os
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numba
import numpy as np

from mona_controller.controllers import CONTROLLERS, Command, Controller
from mona_controller.schema import ParameterError

if TYPE_CHECKING:
    from mona_controller.controller import ControllerParams
    from mona_controller.mona import MonaParams

#: The outputs: left wheel, right wheel, cleaner.
OUTPUTS = 3
#: The widest hidden layer (the recurrent context is held at this width, so that merged
#: controllers of different widths share one array).
MAX_HIDDEN = 64
#: The stream id of seeded weights (controllers use 1, placement another).
NETWORK_STREAM = 7
#: The arrays of a weights file, in genome order.
LAYERS = ('w1', 'b1', 'wr', 'w2', 'b2')
#: Behaviour codes shown to observers (mona_controller.controller's FOLLOW and WAIT).
_MOVING, _CLEANING = 0, 2


def input_count(ir_count: int) -> int:
    """The net's inputs: 2 ground, ``ir_count`` proximities and robot flags, 3 previous."""
    return 2 + 2 * ir_count + OUTPUTS


def shapes(inputs: int, hidden: int, recurrent: bool) -> dict[str, tuple[int, ...]]:
    """Each array's shape, in genome order (``wr`` only if recurrent)."""
    out = {'w1': (hidden, inputs), 'b1': (hidden,), 'wr': (hidden, hidden),
           'w2': (OUTPUTS, hidden), 'b2': (OUTPUTS,)}
    if not recurrent:
        del out['wr']
    return out


def genome_size(ir_count: int, hidden: int, recurrent: bool) -> int:
    """The number of weights of a net (the length of its genome)."""
    return sum(math.prod(shape) for shape in
               shapes(input_count(ir_count), hidden, recurrent).values())


def weights_from_genome(genome: Sequence[float] | np.ndarray, ir_count: int, hidden: int,
                        recurrent: bool) -> dict[str, np.ndarray]:
    """Cut a flat genome into the net's arrays, in :data:`LAYERS` order.

    Raises:
        ValueError: the genome has the wrong length.
    """
    flat = np.asarray(genome, dtype=np.float64)
    expected = genome_size(ir_count, hidden, recurrent)
    if flat.shape != (expected,):
        raise ValueError(f'a genome of {flat.size} weights for a net of {expected}')
    out, start = {}, 0
    for name, shape in shapes(input_count(ir_count), hidden, recurrent).items():
        size = math.prod(shape)
        out[name] = flat[start:start + size].reshape(shape).copy()
        start += size
    return out


def save_weights(path: str | Path, weights: Mapping[str, np.ndarray]) -> str:
    """Write ``weights`` as an .npz, the same bytes for the same weights; its SHA-256."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, 'w', zipfile.ZIP_STORED) as archive:
        for name in LAYERS:
            if name in weights:
                array = io.BytesIO()
                np.lib.format.write_array(array, np.ascontiguousarray(weights[name],
                                                                      dtype=np.float64))
                archive.writestr(zipfile.ZipInfo(f'{name}.npy', (1980, 1, 1, 0, 0, 0)),
                                 array.getvalue())
    data = buffer.getvalue()
    tmp = Path(f'{path}.tmp')
    tmp.write_bytes(data)
    os.replace(tmp, path)
    return hashlib.sha256(data).hexdigest()


@functools.lru_cache(maxsize=256)
def load_weights(path: str, sha256: str) -> dict[str, np.ndarray]:
    """The arrays of a weights file (read-only, cached by path and hash).

    Raises:
        ParameterError: naming ``controller.network_weights``: the file is missing, not an
            .npz of finite float arrays, or its hash is not ``sha256``.
    """
    key = f'controller.network_weights = {path!r}'
    try:
        data = Path(path).read_bytes()
    except OSError as error:
        raise ParameterError(f'{key}: cannot read it ({error.strerror})') from None
    if hashlib.sha256(data).hexdigest() != sha256:
        raise ParameterError(f'{key}: its SHA-256 is not controller.network_weights_sha256 '
                             f'= {sha256!r} (the file changed)')
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            arrays = {name: np.array(archive[name], dtype=np.float64) for name in archive.files}
    except (ValueError, OSError, zipfile.BadZipFile, TypeError) as error:
        raise ParameterError(f'{key}: not an .npz of float arrays ({error})') from None
    for name, array in arrays.items():
        if not np.isfinite(array).all():
            raise ParameterError(f'{key}: {name} holds a value that is not finite')
        array.flags.writeable = False
    return arrays


def check_weights(params: ControllerParams) -> None:
    """Resolve ``params.network_weights`` to an absolute path, fill in its SHA-256 and check
    its arrays fit the declared net (the inputs are checked with the Mona, by the
    controller). Called by ``ControllerParams`` on building.

    Raises:
        ParameterError: naming the key: a missing or bad file, a hash that does not match,
            an array missing, extra or of the wrong shape.
    """
    if not params.network_weights:
        if params.network_weights_sha256:
            raise ParameterError('controller.network_weights_sha256 is set but '
                                 'controller.network_weights is empty')
        return
    path = os.path.abspath(os.path.expanduser(params.network_weights))
    key = f'controller.network_weights = {params.network_weights!r}'
    try:
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError as error:
        raise ParameterError(f'{key}: cannot read {path} ({error.strerror})') from None
    if params.network_weights_sha256 not in ('', digest):
        raise ParameterError(f'{key}: its SHA-256 is {digest}, not '
                             f'controller.network_weights_sha256 = '
                             f'{params.network_weights_sha256!r}')
    arrays = load_weights(path, digest)
    hidden = params.network_hidden
    if hidden > MAX_HIDDEN:
        raise ParameterError(f'controller.network_hidden = {hidden}: at most {MAX_HIDDEN}')
    inputs = arrays['w1'].shape[1] if arrays.get('w1', np.zeros(0)).ndim == 2 else 0
    expected = shapes(inputs, hidden, params.network_recurrent)
    extra = sorted(arrays.keys() - expected.keys())
    if extra:
        raise ParameterError(f'{key}: holds {", ".join(extra)}, not part of a net with '
                             f'network_recurrent = {params.network_recurrent}')
    for name, shape in expected.items():
        if name not in arrays:
            raise ParameterError(f'{key}: lacks {name} (a net with network_recurrent = '
                                 f'{params.network_recurrent} needs {", ".join(expected)})')
        if arrays[name].shape != shape:
            raise ParameterError(f'{key}: {name} is {list(arrays[name].shape)}, a net of '
                                 f'network_hidden = {hidden} needs {list(shape)}')
    object.__setattr__(params, 'network_weights', path)
    object.__setattr__(params, 'network_weights_sha256', digest)


def net_weights(params: ControllerParams, mona: MonaParams) -> dict[str, np.ndarray]:
    """The arrays of ``params``' net for ``mona``: its file's, or drawn from network_seed.

    Raises:
        ParameterError: the file's net has another number of inputs than ``mona`` gives.
    """
    inputs = input_count(mona.ir_count)
    if not params.network_weights:
        rng = np.random.default_rng([NETWORK_STREAM, params.network_seed])
        return {name: rng.normal(size=shape) for name, shape in
                shapes(inputs, params.network_hidden, params.network_recurrent).items()}
    arrays = load_weights(params.network_weights, params.network_weights_sha256)
    if arrays['w1'].shape[1] != inputs:
        raise ParameterError(f'controller.network_weights = {params.network_weights!r}: w1 '
                             f'has {arrays["w1"].shape[1]} inputs, a Mona with '
                             f'{mona.ir_count} IR sensors gives {inputs} (2 ground, '
                             f'{mona.ir_count} proximities, {mona.ir_count} robot flags, '
                             f'{OUTPUTS} previous outputs)')
    return arrays


def top_command(params: ControllerParams, mona: MonaParams) -> float:
    """The wheel command a net's wheel output of 1 stands for: ``mona.max_wheel_command``,
    or with ``network_max_speed`` > 0 that speed in wheel units (worked out as BEECLUST's
    beta is, ``speed / wheel_unit_speed``), within the Mona's top command."""
    if params.network_max_speed == 0.0:
        return float(mona.max_wheel_command)
    return min(params.network_max_speed / mona.wheel_unit_speed, mona.max_wheel_command)


def flatten(arrays: Mapping[str, np.ndarray]) -> np.ndarray:
    """The arrays in :data:`LAYERS` order, as one float64 vector (the kernel's layout)."""
    return np.concatenate([np.ravel(arrays[name]) for name in LAYERS if name in arrays])


@numba.njit(cache=True, nogil=True)
def _softsign(x: float) -> float:
    return x / (1.0 + abs(x))


@numba.njit(cache=True, nogil=True)
def forward(ground, ranges, is_robot, weights, offset, hidden, recurrent, ir_range, top,
            stops, previous, context, wheels, cleaner):  # pragma: no cover (compiled)
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


class NetworkController(Controller):
    """The neural controllers of the robots ``robot_ids`` (the ``network`` kind).

    ``state`` is WAIT (2) while a robot's cleaner is on and FOLLOW (0) otherwise, for
    observers; ``encounters`` stays 0 (a net counts no meetings). A merged controller holds
    every part's net in one vector and each robot's offset into it (:meth:`derive`).
    """

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
        nets = [flatten(net_weights(params, mona))
                for params, mona in zip(self.params, self.mona)]
        starts = np.cumsum([0] + [len(net) for net in nets[:-1]])
        self._weights = np.concatenate(nets)
        index = self.param_index
        self._offset = starts.astype(np.int64)[index]
        self._hidden = np.array([p.network_hidden for p in self.params], np.int64)[index]
        self._recurrent = np.array([p.network_recurrent for p in self.params], bool)[index]
        self._ir_range = np.array([m.ir_range for m in self.mona], np.float64)[index]
        self._top = np.array([top_command(p, m) for p, m in zip(self.params, self.mona)],
                             np.float64)[index]
        self._stops = np.array([p.network_clean_stops for p in self.params], bool)[index]

    def reset(self, seed: int) -> None:
        """Start a new episode: zero outputs and hidden values (a net draws no random
        numbers, so ``seed`` changes nothing)."""
        self.previous[:] = 0.0
        self.context[:] = 0.0
        self.state[:] = _MOVING
        self.encounters[:] = 0

    def step(self, ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray,
             now: float | np.ndarray) -> Command:
        """Every robot's net on its readings: wheels and cleaner (``now`` is not read)."""
        n = len(self.robot_ids)
        wheels = np.empty((n, 2))
        cleaner = np.empty(n, dtype=bool)
        forward(np.asarray(ground, dtype=np.uint8), np.asarray(ranges, dtype=np.float32),
                np.asarray(is_robot, dtype=bool), self._weights, self._offset, self._hidden,
                self._recurrent, self._ir_range, self._top, self._stops, self.previous,
                self.context, wheels, cleaner)
        np.multiply(cleaner, _CLEANING, out=self.state, casting='unsafe')
        return Command(wheels=wheels, cleaner=cleaner)


assert 'network' in CONTROLLERS  # registered by name in mona_controller.controllers
