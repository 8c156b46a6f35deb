"""The network kind's net as arrays: their shapes, a flat genome, and the weights file.

The weights file (``controller.network.weights``) is an ``.npz`` of float64 arrays: ``w1``
[hidden, inputs], ``b1`` [hidden], ``w2`` [3, hidden], ``b2`` [3] and, if recurrent, ``wr``
[hidden, hidden]. :func:`save_weights` writes one byte for byte the same for the same
weights (fixed zip timestamps); :func:`genome_size` and :func:`weights_from_genome` map a
flat genome (neuroevolution) to them; :func:`flatten` lays them out for the kernel
(:mod:`.network_forward`). The ``stand_net`` kind's nets use the same format: it shares
:func:`weights_file` (a kind's file resolved and checked against its hash) and
:func:`cut_genome`.
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

import numpy as np

from mona_controller.schema import ParameterError

#: The outputs: left wheel, right wheel, cleaner.
OUTPUTS = 3
#: The widest hidden layer (the recurrent context is held at this width, so that merged
#: controllers of different widths share one array).
MAX_HIDDEN = 64
#: The arrays of a weights file, in genome order.
LAYERS = ('w1', 'b1', 'wr', 'w2', 'b2')

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
    return cut_genome(genome, shapes(input_count(ir_count), hidden, recurrent))


def cut_genome(genome: Sequence[float] | np.ndarray,
               layout: Mapping[str, tuple[int, ...]]) -> dict[str, np.ndarray]:
    """Cut a flat genome into arrays of the shapes ``layout`` gives, in its order (the
    network kind's :func:`shapes`, or another kind's of the same format).

    Raises:
        ValueError: the genome has the wrong length.
    """
    flat = np.asarray(genome, dtype=np.float64)
    expected = sum(math.prod(shape) for shape in layout.values())
    if flat.shape != (expected,):
        raise ValueError(f'a genome of {flat.size} weights for a net of {expected}')
    out, start = {}, 0
    for name, shape in layout.items():
        size = math.prod(shape)
        out[name] = flat[start:start + size].reshape(shape).copy()
        start += size
    return out


def save_weights(path: str | Path, weights: Mapping[str, np.ndarray]) -> str:
    """Write ``weights`` as an .npz, the same bytes for the same weights; its SHA-256."""
    buffer = io.BytesIO()
    archive = zipfile.ZipFile(buffer, 'w', zipfile.ZIP_STORED)
    try:
        for name in LAYERS:
            if name in weights:
                array = io.BytesIO()
                np.lib.format.write_array(array, np.ascontiguousarray(weights[name],
                                                                      dtype=np.float64))
                archive.writestr(zipfile.ZipInfo(f'{name}.npy', (1980, 1, 1, 0, 0, 0)),
                                 array.getvalue())
    except BaseException:
        # An exception amid writestr (a Ctrl-C's, raised by a signal handler) can leave the
        # archive marked as writing a member, and closing it, as a with block would, raises
        # ValueError in that exception's place (an interrupted evolution exited 1 with a
        # traceback, not 130). The unfinished archive is dropped: with no file, close(),
        # also the one at garbage collection, does nothing.
        archive.fp = None
        raise
    archive.close()
    data = buffer.getvalue()
    tmp = Path(f'{path}.tmp')
    tmp.write_bytes(data)
    os.replace(tmp, path)
    return hashlib.sha256(data).hexdigest()


@functools.lru_cache(maxsize=256)
def load_weights(path: str, sha256: str) -> dict[str, np.ndarray]:
    """The arrays of a weights file (read-only, cached by path and hash).

    Raises:
        ParameterError: naming ``controller.network.weights``: the file is missing, not an
            .npz of finite float arrays, or its hash is not ``sha256``.
    """
    key = f'controller.network.weights = {path!r}'
    try:
        data = Path(path).read_bytes()
    except OSError as error:
        raise ParameterError(f'{key}: cannot read it ({error.strerror})') from None
    if hashlib.sha256(data).hexdigest() != sha256:
        raise ParameterError(f'{key}: its SHA-256 is not controller.network.weights_sha256 '
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


def weights_file(kind: str, weights: str, weights_sha256: str
                 ) -> tuple[str, str, str, dict[str, np.ndarray]] | None:
    """A kind's weights file (``controller.<kind>.weights`` and ``.weights_sha256``), resolved
    and checked against its hash: (the key, as error messages name it; the absolute path; its
    SHA-256; its arrays), or None where no file is named. Whether the arrays fit the kind's
    net is the kind's to check.

    Raises:
        ParameterError: naming the key: a hash without a file, a missing or bad file, a hash
            that does not match.
    """
    if not weights:
        if weights_sha256:
            raise ParameterError(f'controller.{kind}.weights_sha256 is set but '
                                 f'controller.{kind}.weights is empty')
        return None
    path = os.path.abspath(os.path.expanduser(weights))
    key = f'controller.{kind}.weights = {weights!r}'
    try:
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError as error:
        raise ParameterError(f'{key}: cannot read {path} ({error.strerror})') from None
    if weights_sha256 not in ('', digest):
        raise ParameterError(f'{key}: its SHA-256 is {digest}, not '
                             f'controller.{kind}.weights_sha256 = {weights_sha256!r}')
    return key, path, digest, load_weights(path, digest)


def flatten(arrays: Mapping[str, np.ndarray]) -> np.ndarray:
    """The arrays in :data:`LAYERS` order, as one float64 vector (the kernel's layout)."""
    return np.concatenate([np.ravel(arrays[name]) for name in LAYERS if name in arrays])
