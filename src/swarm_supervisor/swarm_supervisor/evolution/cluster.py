"""A generation's batches on the study's Dask scheduler (``mona-swarm evolve --scheduler``).

:class:`ClusterPool` has the part of a ``multiprocessing.Pool`` the evolution uses
(``map``, ``close``, ``terminate``, ``join``), so :func:`~swarm_supervisor.evolution.fitness.
run_scores` runs its batches of episodes on either. It connects with the study's client
(:func:`swarm_supervisor.study.cluster.connect`: the same address, timeout and error). Each
batch is one task that carries the bytes of the weights files its episodes name
(:func:`portable`); the worker writes them into a temporary folder of its own and points the
episodes at them, their SHA-256 checked on loading (:func:`run_portable`). So the workers
need no shared filesystem, only the same packages, and as a robot computes the same bits in
any batch and any process, the scores are those of the local pool. A worker that dies loses
only its task: the scheduler runs it again on another.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.study.cluster import CONNECT_TIMEOUT, connect

#: One task: the episodes of a batch and the weights files they name (path -> bytes).
Portable = tuple[list[SwarmConfig], dict[str, bytes]]


def weights_of(config: SwarmConfig) -> str:
    """The weights file the episode's controller kind names ('' if none)."""
    section = getattr(config.controller, config.controller.kind, None)
    return str(getattr(section, 'weights', ''))


def portable(configs: Sequence[SwarmConfig]) -> Portable:
    """A batch with the bytes of every weights file its episodes name."""
    files = {weights_of(config): Path(weights_of(config)).read_bytes()
             for config in configs if weights_of(config)}
    return list(configs), files


def run_portable(func: Callable[[Sequence[SwarmConfig]], Any], task: Portable) -> Any:
    """Worker side: write the task's weights files into a temporary folder, point its
    episodes at them (the hashes stay, so a file changed on the way is refused) and run
    ``func`` on the episodes."""
    configs, files = task
    with tempfile.TemporaryDirectory(prefix='mona-evolve-') as scratch:
        local = {}
        for k, (path, data) in enumerate(files.items()):
            local[path] = Path(scratch) / f'{k}_{Path(path).name}'
            local[path].write_bytes(data)
        moved = [config.replace(controller={config.controller.kind: {
            'weights': str(local[weights_of(config)])}})
            if weights_of(config) else config for config in configs]
        return func(moved)


class ClusterPool:
    """The evolution's pool on the workers of a Dask scheduler.

    ``jobs`` is the cluster's thread count when it connected (batches are cut into at least
    as many; the cut does not change a score).
    """

    def __init__(self, scheduler: str, timeout: float = CONNECT_TIMEOUT) -> None:
        """Connect to ``scheduler`` (e.g. ``tcp://10.0.0.1:8786``).

        Raises:
            ClusterError: it does not answer within ``timeout`` s.
        """
        self.client = connect(scheduler, timeout)
        self.jobs = max(1, sum(self.client.nthreads().values()))
        self._futures: list[Any] = []

    def map(self, func: Callable[[Sequence[SwarmConfig]], Any],
            batches: Sequence[Sequence[SwarmConfig]], chunksize: int = 1) -> list[Any]:
        """``func`` of each batch, in order, each batch one task (``chunksize`` is the
        multiprocessing signature's and is ignored)."""
        self._futures = [self.client.submit(run_portable, func, portable(batch), pure=False)
                         for batch in batches]
        results = self.client.gather(self._futures)
        self._futures = []
        return list(results)

    def close(self) -> None:
        """Disconnect (the cluster keeps running)."""
        self.client.close()

    def terminate(self) -> None:
        """Cancel the tasks still pending (Ctrl-C, an error) and disconnect."""
        if self._futures:
            self.client.cancel(self._futures)
        self.client.close()

    def join(self) -> None:
        """Nothing to wait for: the workers are the cluster's."""
