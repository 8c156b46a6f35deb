"""Numba's on-disk cache filled once, in one process, before anything compiles in parallel.

Every compiled kernel of the four packages is ``@numba.njit(cache=True)``: the first process
to call one compiles it and writes its cache files beside the source (``__pycache__``, or
``NUMBA_CACHE_DIR``); later processes load them. Numba does not guard those writes against
each other, and processes compiling the same kernel at once can leave a cache that crashes
whoever loads it (numba/numba#4807, numba/numba#10128). :func:`warm_kernels` runs the
smallest real work that reaches every cached kernel with the argument types the project uses
(a few steps of a tiny episode per feature, alone and batched, and their metrics), so that
``make venv``, the test suite's controller and the launcher can fill the cache serially
before they start processes side by side. Pure (no ROS).

``python -m swarm_supervisor.engine.warm`` runs it and prints what it warmed and how long it
took (seconds: the compilation on a fresh install, about a second once cached).
"""

from __future__ import annotations

import dataclasses
import sys
import time
from collections.abc import Iterator

import numba
import numpy as np
from numba.core.caching import FunctionCache
from numba.core.registry import CPUDispatcher

from swarm_metrics.metrics import ALL_PAIRS_MAX, coherency
from swarm_supervisor.config import SwarmConfig, load_config, shipped
from swarm_supervisor.engine.runner import run_batch, run_episode
from swarm_world.company import in_company
from swarm_world.sensing.ground import field_list, set_field

#: The packages whose cached kernels are warmed.
PACKAGES = ('mona_controller', 'swarm_world', 'swarm_metrics', 'swarm_supervisor')
#: Steps per episode: enough for a control step, a cleaning tick, a transport tick and a
#: metrics sample (each 1 s at most by the shipped defaults).
WARM_DURATION = 1.1
#: Each feature that takes kernels (or argument types) of its own, as parameter overrides.
FEATURES: dict[str, dict[str, object]] = {
    'obstacles, noise, latency': {
        'world.obstacles': {'pillar': [0.9, 0.9, 0.1], 'wall': [1.0, 2.3, 1.85, 2.36]},
        'sensing.ground_noise': 2.0, 'sensing.ir_miss': 0.1, 'sensing.wheel_noise': 0.05,
        'sensing.command_latency': 1},
    'moving leaking sources': {
        'world.sources': {'west': [0.8, 2.0, 0.5, 255.0], 'east': [2.1, 0.9, 0.6, 255.0]},
        'world.source_profile': {'east': ['gaussian']},
        'world.source_emission': {'west': [0.5], 'east': [0.5]},
        'world.source_velocity': {'west': [0.002, -0.001]},
        'world.source_path': {'east': [0.003, 2.1, 1.9, 1.5, 1.4]},
        'world.diffusion': 0.0001, 'world.half_life': 1000.0},
}
#: Controllers with compiled kernels of their own, by their shipped parameter file.
CONTROLLERS = ('controllers/evolved.yaml', 'controllers/stand_net.yaml')


@dataclasses.dataclass(frozen=True)
class Warmed:
    """What :func:`warm_kernels` did."""

    kernels: int  #: cached kernels of the packages imported (compiled or loaded)
    signatures: int  #: their compiled or loaded signatures
    seconds: float  #: wall time

    def __str__(self) -> str:
        return (f'warmed {self.kernels} cached numba kernels ({self.signatures} signatures) '
                f'in {self.seconds:.1f} s')


def cached_kernels() -> Iterator[tuple[str, CPUDispatcher]]:
    """(dotted name, dispatcher) of every ``cache=True`` kernel in the imported modules of
    :data:`PACKAGES` (defined there: a kernel imported into another module counts once)."""
    for name, module in sorted(sys.modules.items()):
        if name.split('.')[0] not in PACKAGES or module is None:
            continue
        for attribute, value in sorted(vars(module).items()):
            if (isinstance(value, CPUDispatcher) and value.__module__ == name
                    and isinstance(getattr(value, '_cache', None), FunctionCache)):
                yield f'{name}.{attribute}', value


def configs(population: int = 4) -> list[SwarmConfig]:
    """The tiny episodes that reach every cached kernel: the shipped default (BEECLUST), each
    of :data:`FEATURES`, each of :data:`CONTROLLERS` also with one robot (as a controller
    node steps it: its arrays of one robot can be read-only views, another signature)."""
    tiny = {'episode.population': population, 'episode.duration': WARM_DURATION}
    base = load_config().with_values(tiny)
    found = [base, *(base.with_values(values) for values in FEATURES.values())]
    for name in CONTROLLERS:
        controller = load_config(shipped(name)).with_values(tiny)
        found += [controller, controller.with_values({'episode.population': 1})]
    return found


def warm_kernels() -> Warmed:
    """Compile, or load from numba's cache, every cached kernel of the four packages for the
    argument types the project passes, by running each of :func:`configs` alone and the
    default with the first feature as a batch (the batched kernels).

    Run it in one process before starting several that use the kernels (it makes no
    process of its own). Cheap once the cache is warm: the kernels load, the episodes last
    about 35 steps.
    """
    started = time.perf_counter()
    episodes = configs()
    for config in episodes:
        run_episode(config)
    run_batch(episodes[:2])  # one arena with obstacles and one without
    run_batch(episodes[:1])  # none with obstacles
    # What a tiny episode does not reach, called as the world and the metrics call it: the
    # cleaning quorum's count (a cleaning tick with robots cleaning, world.cleaning_quorum
    # > 1), coherency beyond ALL_PAIRS_MAX robots and a batch's sensed field replaced.
    in_company(np.arange(3), np.zeros((3, 3)), 2, 0.1)
    # A batch's sensed field replaced after cleaning (float32, as World.sensed_field's).
    set_field(field_list([np.zeros((2, 2), np.float32)]), 0, np.zeros((2, 2), np.float32))
    coherency(np.zeros((ALL_PAIRS_MAX + 1, 2)))
    kernels = list(cached_kernels())
    return Warmed(kernels=len(kernels), signatures=sum(len(k.signatures) for _, k in kernels),
                  seconds=time.perf_counter() - started)


def main() -> None:
    """Warm the kernels and say so (``python -m swarm_supervisor.engine.warm``)."""
    print(f'{warm_kernels()} (numba {numba.__version__})')


if __name__ == '__main__':
    main()
