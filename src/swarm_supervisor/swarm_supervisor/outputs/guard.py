"""Never write over a record: an output folder that already holds a run, a study or a bag is
refused unless the user says ``--overwrite``, and then it is replaced whole, never mixed.

Every command that writes a folder calls :func:`claim_output` before it starts a process or
writes a byte; a study, which resumes into its own folder, asks :func:`record_in` what is
there and decides itself.
"""

from __future__ import annotations

import shutil
from pathlib import Path

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


class RecordExists(ValueError):
    """An output folder holds a record and ``--overwrite`` was not given (exit status 2)."""


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


def claim_output(folder: Path, *, overwrite: bool, option: str = '--out') -> Path:
    """Make ``folder`` ready for a new record: refuse (:class:`RecordExists`) if it holds one
    and ``overwrite`` is false; with ``overwrite``, delete it whole first. Returns the folder.

    A path that exists and is not a folder is refused either way: overwrite replaces records,
    not arbitrary files.
    """
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise RecordExists(f'{option} {folder} is a file, not a folder: choose another {option}')
    found = record_in(folder)
    if found is None:
        return folder
    what, marker = found
    if not overwrite:
        raise RecordExists(
            f'{option} {folder} already holds {what} ({marker}): choose another {option}, or '
            'pass --overwrite to replace it whole')
    shutil.rmtree(folder)
    return folder
