"""The launcher's output folder: the default one is always new, and a given ``--out`` never
receives a run over an earlier record (outputs.guard's rule, plus the files a node-system run
leaves, :func:`~swarm_supervisor.system.preflight.node_run_in`)."""

from __future__ import annotations

import time
from pathlib import Path

from swarm_supervisor.outputs.guard import RecordExists, check_output, claim_output, empty
from swarm_supervisor.system.preflight import node_run_in


def claim_out(out: Path, overwrite: bool) -> None:
    """Make ``out`` ready for the run (:func:`~swarm_supervisor.outputs.guard.claim_output`:
    created and locked): a folder holding an earlier record, also a node-system run that the
    guard's markers miss (:func:`~swarm_supervisor.system.preflight.node_run_in`), is refused
    unless ``overwrite``, which empties it: a run never writes beside an old bag.

    Raises:
        RecordExists: naming the folder, what it holds and ``--overwrite``.
    """
    check_output(out, overwrite=overwrite)
    marker = node_run_in(out)
    if marker is not None and not overwrite:
        raise RecordExists(f'--out {out} already holds a node-system run ({marker}): choose '
                           'another --out, or pass --overwrite to replace it whole')
    claim_output(out, overwrite=overwrite)  # created and locked while the run lasts
    if marker is not None:
        empty(out)


def default_out() -> Path:
    """results/swarm-<date>-<time> in the current directory, with -2, -3, ... if a run of the
    same second has it."""
    base = Path.cwd() / 'results' / f'swarm-{time.strftime("%Y%m%d-%H%M%S")}'
    out, n = base, 2
    while out.exists():
        out, n = base.with_name(f'{base.name}-{n}'), n + 1
    return out
