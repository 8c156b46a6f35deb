"""Never write over a record: an output folder that already holds a run, a study or a bag is
refused unless the user says ``--overwrite``, and then it is replaced whole, never mixed.

Every command that writes a folder calls :func:`claim_output` before it starts a process or
writes a byte (or :func:`check_output` first, to refuse before its work and claim after); a
study, which resumes into its own folder, asks :func:`record_in` what is there and decides
itself. A claimed folder is locked while the command runs (:mod:`.lock`), and a place that
cannot take a folder is refused up front (:mod:`.location`).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from swarm_supervisor.outputs.lock import RecordExists, check_free, hold

#: The files that make a folder a record, and what each says the folder holds. A folder is a
#: record if one of them is in it or in a folder directly below it (a study's episodes, a
#: node-system run's ``episode_*``, a bag under ``bag/``).
RECORD_FILES = {
    'study.json': 'a study',
    'all_metrics.csv': 'a study',
    'run.json': 'a node-system run',
    'episode.json': 'an episode',
    'metrics.csv': 'an episode',
    'metadata.yaml': 'a bag',
}


def record_in(folder: Path) -> tuple[str, Path] | None:
    """What record ``folder`` holds and the file that says so, or None for a folder that is
    absent, empty or holds no record (a file of another kind, such as a plot, is no record)."""
    folder = Path(folder)
    if not folder.is_dir():
        return None
    levels = [folder] + sorted(p for p in folder.iterdir() if p.is_dir())
    for place in levels:
        for name, what in RECORD_FILES.items():
            marker = place / name
            if marker.is_file():
                return what, marker
        if any(place.glob('*.mcap')):
            return 'a bag', next(iter(sorted(place.glob('*.mcap'))))
    return None


def check_place(folder: Path, option: str = '--out') -> Path:
    """Refuse ``folder`` as an output folder, creating nothing: a file, a path that cannot
    take a folder (:func:`~swarm_supervisor.outputs.location.check_location`), or a folder
    being written by another process (:mod:`~swarm_supervisor.outputs.lock`).

    Raises:
        RecordExists: a file, or another writer (naming it where the system says).
        OutputError: the path cannot take a folder.
    """
    from swarm_supervisor.outputs.location import check_location

    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise RecordExists(f'{option} {folder} is a file, not a folder: choose another {option}')
    check_location(folder, option)
    check_free(folder, option)
    return folder


def check_output(folder: Path, *, overwrite: bool, option: str = '--out') -> Path:
    """Refuse ``folder`` as a new record's place, creating nothing: what
    :func:`check_place` refuses, and a folder holding a record without ``overwrite``.
    Returns the folder.

    Raises:
        RecordExists: naming the folder and what it holds (or who writes it).
        OutputError: the path cannot take a folder.
    """
    folder = check_place(folder, option)
    found = record_in(folder)
    if found is not None and not overwrite:
        what, marker = found
        raise RecordExists(
            f'{option} {folder} already holds {what} ({marker}): choose another {option}, or '
            'pass --overwrite to replace it whole')
    return folder


def claim_output(folder: Path, *, overwrite: bool, option: str = '--out') -> Path:
    """Make ``folder`` ready for a new record (:func:`check_output` first): create it and
    hold its lock while this process runs; with ``overwrite``, empty it first of a record it
    holds. Returns the folder.

    A path that exists and is not a folder is refused either way: overwrite replaces records,
    not arbitrary files.
    """

    check_output(folder, overwrite=overwrite, option=option)
    folder = hold(folder, option)  # locked before anything in it is deleted
    if record_in(folder) is not None:
        empty(folder)
    return folder


def empty(folder: Path) -> None:
    """Delete everything in ``folder``, keeping the folder (and so the lock held on it)."""
    for entry in folder.iterdir():
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry)
        else:
            entry.unlink()
