"""One writer per output folder: a command holds a lock on the folder it writes for as long as
it runs, and a second command into the same folder is refused before it does any work.

The lock is ``flock`` on the folder itself (nothing is written to hold it; the kernel lets
it go when the process ends, however it ends). Two studies started into one folder at once, or
a ``run --overwrite`` into a folder a study is writing, would otherwise mix or delete each
other's files.
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path


class RecordExists(ValueError):
    """An output folder holds a record and ``--overwrite`` was not given, or another process
    writes it (exit status 2)."""


#: The folders this process holds: resolved path -> the open descriptor holding the lock.
_HELD: dict[Path, int] = {}
LOCKS = Path('/proc/locks')


class FolderBusy(RecordExists):
    """Another process is writing the folder (exit status 2)."""


def _try_lock(folder: Path) -> int | None:
    """An open descriptor of ``folder`` holding its lock, or None if another process has it."""
    descriptor = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(descriptor)
        return None
    return descriptor


def _busy(folder: Path, option: str) -> FolderBusy:
    holder = writer_of(folder)
    return FolderBusy(f'{option} {folder} is being written by another process'
                      f'{f" ({holder})" if holder else ""}: wait until it ends, or choose '
                      f'another {option}')


def check_free(folder: str | Path, option: str = '--out') -> None:
    """Refuse ``folder`` if another process holds its lock (nothing is created).

    Raises:
        FolderBusy: naming the folder and, where the system says, the writer.
    """
    folder = Path(folder)
    if not folder.is_dir() or folder.resolve() in _HELD:
        return
    descriptor = _try_lock(folder)
    if descriptor is None:
        raise _busy(folder, option)
    os.close(descriptor)  # closing the only descriptor lets the lock go


def hold(folder: str | Path, option: str = '--out') -> Path:
    """Create ``folder`` if needed and hold its lock until this process ends.

    Raises:
        FolderBusy: another process holds it.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    key = folder.resolve()
    if key not in _HELD:
        descriptor = _try_lock(folder)
        if descriptor is None:
            raise _busy(folder, option)
        _HELD[key] = descriptor
    return folder


def release(folder: str | Path) -> None:
    """Let ``folder``'s lock go (a no-op if this process does not hold it)."""
    descriptor = _HELD.pop(Path(folder).resolve(), None)
    if descriptor is not None:
        os.close(descriptor)


def writer_of(folder: Path) -> str:
    """Who holds ``folder``'s lock, from /proc/locks: 'pid P: its command line', or ''."""
    try:
        stat = folder.stat()
        lines = LOCKS.read_text().splitlines()
    except OSError:
        return ''
    device = f'{os.major(stat.st_dev):02x}:{os.minor(stat.st_dev):02x}:{stat.st_ino}'
    for line in lines:
        fields = line.split()
        if len(fields) > 5 and fields[1] == 'FLOCK' and fields[5] == device:
            try:
                command = Path(f'/proc/{fields[4]}/cmdline').read_bytes()
            except OSError:
                return f'pid {fields[4]}'
            words = command.replace(b'\0', b' ').decode(errors='replace').strip()
            return f'pid {fields[4]}: {words}'
    return ''
