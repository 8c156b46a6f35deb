"""The study's episodes on a Dask distributed cluster (``mona-swarm study --scheduler``).

Each batch of episodes (:func:`swarm_supervisor.study.tasks.make_batches`) is one Dask task. A
worker runs it into temporary folders of its own and sends back each folder's files as bytes;
the client writes them into the study's folder, episode.json last, exactly as a local run
does. So the workers need no shared filesystem, only the same
packages (this project installed in the same Python), and the outputs are the same files a
local run writes. A worker that dies mid-batch loses only that task: the scheduler runs it
again on another worker (Dask gives up on a task only after it has killed
``distributed.scheduler.allowed-failures`` workers, 3 by default).
"""

from __future__ import annotations

import dataclasses
import hashlib
import shutil
import socket
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from tqdm import tqdm

from swarm_supervisor import outputs
from swarm_supervisor.study.errors import StudyError
from swarm_supervisor.study.interrupt import Interrupted
from swarm_supervisor.study.progress import show_done
from swarm_supervisor.study.tasks import (
    EpisodeTask,
    move_into_place,
    partial_folder,
    run_and_write,
)

#: Seconds to wait for the scheduler to answer before giving up (default).
CONNECT_TIMEOUT = 30.0
#: The address schemes of a scheduler other processes can reach (Dask's comm backends less
#: 'inproc', which lives in one process).
NETWORK_SCHEMES = ('tcp', 'tls', 'ws', 'wss', 'ucx')


class ClusterError(StudyError):
    """The scheduler cannot be reached (the command line exits 2 with this message)."""


def episode_files(tasks: Sequence[EpisodeTask]) -> list[tuple[str, float, float,
                                                               dict[str, bytes]]]:
    """Worker side: run a batch of episodes into temporary folders (with the function a local
    worker runs) and return their files.

    Returns:
        Per episode: (the study's folder for it, wall s, CPU s, relative file path -> bytes).
    """
    with tempfile.TemporaryDirectory(prefix='mona-batch-') as scratch:
        folders = [str(Path(scratch) / str(k)) for k in range(len(tasks))]
        ran = run_and_write([dataclasses.replace(task, folder=folder)
                             for task, folder in zip(tasks, folders)])
        out = []
        for task, folder, (_, wall, cpu) in zip(tasks, folders, ran):
            files = {str(path.relative_to(folder)): path.read_bytes()
                     for path in sorted(Path(folder).rglob('*')) if path.is_file()}
            out.append((task.folder, wall, cpu, files))
    return out


def write_files(folder: str | Path, files: dict[str, bytes]) -> None:
    """Client side: write an episode's files under a temporary name, episode.json last, and
    rename that into place (:func:`~swarm_supervisor.study.tasks.move_into_place`), so the
    folder is whole or absent whenever the client stops, as in a local run."""
    partial = partial_folder(folder)
    shutil.rmtree(partial, ignore_errors=True)
    partial.mkdir(parents=True)
    for name, data in files.items():
        if name != outputs.EPISODE_FILE:
            (partial / name).parent.mkdir(parents=True, exist_ok=True)
            (partial / name).write_bytes(data)
    (partial / outputs.EPISODE_FILE).write_bytes(files[outputs.EPISODE_FILE])
    move_into_place(partial, folder)


def check_address(scheduler: str) -> None:
    """Refuse at once what cannot be a scheduler's address (Dask would retry it until its
    timeout, then fail deep inside): an unknown scheme, no port, a port out of range, a host
    name that does not resolve, or an in-process address.

    Raises:
        ClusterError: naming the address, what is wrong and the form to give.
    """
    from distributed.comm.addressing import parse_address, parse_host_port

    form = 'give tcp://HOST:PORT, e.g. tcp://10.0.0.1:8786'
    scheme, location = parse_address(scheduler)
    if scheme not in NETWORK_SCHEMES:
        raise ClusterError(f'--scheduler {scheduler}: {scheme}:// is not a scheme of a Dask '
                           f'scheduler on the network ({", ".join(NETWORK_SCHEMES)}): {form}')
    try:
        host, port = parse_host_port(location)
    except ValueError:
        raise ClusterError(f'--scheduler {scheduler}: no port: {form}') from None
    if not host or not 1 <= port <= 65535:
        raise ClusterError(f'--scheduler {scheduler}: expected a host and a port in 1..65535: '
                           f'{form}')
    try:
        socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError) as error:
        raise ClusterError(f'--scheduler {scheduler}: the host {host} is unknown '
                           f'({getattr(error, "strerror", None) or error}): {form}') from None


def connect(scheduler: str, timeout: float = CONNECT_TIMEOUT):  # -> distributed.Client
    """A client of the Dask scheduler at ``scheduler`` (also ``mona-swarm evolve``'s), its
    address checked first (:func:`check_address`).

    Raises:
        ClusterError: dask.distributed is missing, the address is not one, or the scheduler
            does not answer within ``timeout`` s.
    """
    try:
        from dask.distributed import Client
    except ImportError as error:  # pragma: no cover - dask is a requirement
        raise ClusterError(f'--scheduler needs dask.distributed ({error})') from None
    check_address(scheduler)
    try:
        return Client(scheduler, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError) as error:
        raise ClusterError(f'cannot reach the Dask scheduler at {scheduler}: {error}') \
            from None


def run_on_cluster(batches: Sequence[Sequence[EpisodeTask]],
                   scheduler: str, progress: bool | None, timeout: float = CONNECT_TIMEOUT,
                   client: Any = None) -> dict[str, tuple[float, float]]:
    """Run the batches of tasks on the cluster of ``scheduler`` (e.g. ``tcp://10.0.0.1:8786``),
    with ``client`` if it is connected already (it is closed at the end either way).

    Episodes are written as they finish; Ctrl-C, SIGTERM or a failed episode cancels the
    rest (the finished ones stay, and the next call resumes from them).

    Returns:
        folder -> (wall seconds, CPU seconds) of each episode, on its worker.

    Raises:
        ClusterError: the scheduler does not answer within ``timeout`` s.
        Interrupted: stopped by a signal; its ``ran`` holds the episodes written before.
    """
    pending = [task for batch in batches for task in batch]
    if not pending:
        if client is not None:
            client.close()
        return {}
    client = client or connect(scheduler, timeout)
    from dask.distributed import as_completed
    ran: dict[str, tuple[float, float]] = {}
    futures = []
    try:
        # Keys name the batch's first episode and its study folder, so two studies never
        # share a task.
        for batch in batches:
            first = Path(batch[0].folder)
            digest = hashlib.sha1(str(first.resolve()).encode()).hexdigest()[:12]
            futures.append(client.submit(episode_files, list(batch), pure=False,
                                         key=f'{first.name}+{len(batch) - 1}-{digest}'))
        with tqdm(total=len(pending), desc='episodes', unit='episodes', file=sys.stderr,
                  disable=None if progress is None else not progress) as bar:
            for future in as_completed(futures, loop=client.loop):
                for folder, wall, cpu, files in future.result():
                    write_files(folder, files)
                    ran[folder] = wall, cpu
                    show_done(bar, progress, len(ran), len(pending), folder, wall)
    except Interrupted as stopped:
        stopped.announce()
        stopped.ran = dict(ran)
        raise
    finally:
        client.cancel([f for f in futures if not f.done()])
        client.close()
    return ran
