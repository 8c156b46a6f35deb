"""What a genome is, for each controller kind an evolution may evolve (``evolve.kind``).

An :class:`Architecture` says how long a kind's genome is, how a genome becomes the arrays
of its weights file, which ``controller`` keys run those weights with the design's limits,
and the genome a search starts from (``evolve.start``: all zero, or one that drives).

- ``network`` (:mod:`mona_controller.controllers.network`): the first net, kept as an ablation. Its
  ``drives`` start sets both wheel outputs' biases to 1 (softsign 0.5: half the top speed,
  straight ahead) and everything else to 0, so the cleaner output is 0 (off).
- ``stand_net`` (:mod:`mona_controller.controllers.stand_net`): the net that decides its
  stands at the cleaning ticks. Its ``drives`` start: both wheel biases 1 (half the top
  speed, straight ahead) and the stand's logit bias -1 (it stands for a period with
  probability 1/4), everything else 0: a swarm that drives from generation 0.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from mona_controller.controllers import network_weights as network
from mona_controller.controllers import stand_net

#: A :class:`swarm_supervisor.evolution.design.Design` (which imports this module, so it is
#: not imported here): the architectures read its base, kind, start, hidden, recurrent,
#: max_speed, clean_stops and genome_size.
Design = Any


@dataclasses.dataclass(frozen=True)
class Architecture:
    """A kind's genome: its length, its weights, its controller keys and its start."""

    size: Callable[[Design], int]
    weights: Callable[[Design, np.ndarray], dict[str, np.ndarray]]
    section: Callable[[Design, str], dict[str, Any]]
    drives: Callable[[Design], np.ndarray]


def _network_size(design: Design) -> int:
    return network.genome_size(design.base.mona.ir_count, design.hidden, design.recurrent)


def _network_weights(design: Design, genome: np.ndarray) -> dict[str, np.ndarray]:
    return network.weights_from_genome(genome, design.base.mona.ir_count, design.hidden,
                                       design.recurrent)


def _network_section(design: Design, weights: str) -> dict[str, Any]:
    return {'kind': 'network', 'network': {
        'hidden': design.hidden, 'recurrent': design.recurrent, 'weights': weights,
        'weights_sha256': '', 'max_speed': design.max_speed,
        'clean_stops': design.clean_stops}}


def _network_drives(design: Design) -> np.ndarray:
    arrays = _network_weights(design, np.zeros(_network_size(design)))
    arrays['b2'][:2] = 1.0  # left and right wheels at half the top command; cleaner off
    return network.flatten(arrays)


def _stand_size(design: Design) -> int:
    return stand_net.genome_size(design.base.mona.ir_count, design.hidden)


def _stand_weights(design: Design, genome: np.ndarray) -> dict[str, np.ndarray]:
    return stand_net.weights_from_genome(genome, design.base.mona.ir_count, design.hidden)


def _stand_section(design: Design, weights: str) -> dict[str, Any]:
    return {'kind': 'stand_net', 'stand_net': {
        'hidden': design.hidden, 'weights': weights, 'weights_sha256': '',
        'max_speed': design.max_speed}}


def _stand_drives(design: Design) -> np.ndarray:
    arrays = _stand_weights(design, np.zeros(_stand_size(design)))
    arrays['b2'][:] = (1.0, 1.0, -1.0)  # half the top speed; stand with probability 1/4
    return network.flatten(arrays)


#: The kinds an evolution may evolve, by ``evolve.kind``.
ARCHITECTURES: dict[str, Architecture] = {
    'network': Architecture(_network_size, _network_weights, _network_section,
                            _network_drives),
    'stand_net': Architecture(_stand_size, _stand_weights, _stand_section, _stand_drives),
}


def architecture(kind: str) -> Architecture:
    """The architecture of ``kind`` (one of :data:`ARCHITECTURES`)."""
    return ARCHITECTURES[kind]


def start_genome(design: Design) -> np.ndarray:
    """The genome the design's search starts from (``evolve.start``)."""
    if design.start == 'zero':
        return np.zeros(design.genome_size)
    return architecture(design.kind).drives(design)


def save_genome(design: Design, genome: np.ndarray, path: Path) -> str:
    """Write ``genome`` as the kind's weights file at ``path``; its SHA-256."""
    return network.save_weights(path, architecture(design.kind).weights(design, genome))
