"""Can an output go where the user says? Checked before any work, so that a path that cannot
take it fails in one line instead of at the first write, after the run.

Refused: a path under a file (``--out notes.txt/run``), one on a pseudo file system (/proc,
/sys, cgroups: the kernel's view of the system, not storage; a folder made there may even be
a kernel object, such as a new cgroup), one on a read-only file system, and one in a folder
this user may not write. Nothing is created to find out: the nearest existing folder is
looked at (``os.access``, and the mount table for the file system's type and options).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from mona_controller.schema import ParameterError

#: File system types that hold no files of ours (Linux's pseudo file systems).
PSEUDO_FILE_SYSTEMS = frozenset({
    'proc', 'sysfs', 'cgroup', 'cgroup2', 'devpts', 'debugfs', 'tracefs', 'securityfs',
    'configfs', 'pstore', 'bpf', 'mqueue', 'fusectl', 'efivarfs', 'binfmt_misc', 'nsfs',
    'rpc_pipefs', 'autofs', 'hugetlbfs', 'devtmpfs'})
MOUNTS = Path('/proc/self/mountinfo')


class OutputError(ParameterError):
    """An output location that cannot take the output (exit status 2, nothing written)."""


def mount_of(path: Path) -> tuple[str, str, set[str]] | None:
    """(mount point, file system type, mount options) of the mount holding the existing
    ``path``, or None where the mount table cannot be read (not Linux)."""
    try:
        lines = MOUNTS.read_text().splitlines()
    except OSError:
        return None
    real = os.path.realpath(path)
    best: tuple[str, str, set[str]] | None = None
    for line in lines:
        fields = line.split()
        if '-' not in fields:
            continue
        point = re.sub(r'\\([0-7]{3})', lambda m: chr(int(m.group(1), 8)), fields[4])
        after = fields[fields.index('-') + 1:]  # type, source, the super block's options
        inside = real == point or real.startswith(point.rstrip('/') + '/')
        if inside and (best is None or len(point) >= len(best[0])):
            options = set(fields[5].split(',')) | set(after[-1].split(','))
            best = (point, after[0], options)
    return best


def check_location(path: str | Path, option: str = '--out', *, kind: str = 'folder') -> None:
    """Refuse ``path`` as the place of an output ``kind`` ('folder' or 'file') if it cannot
    be written there. A path that exists is not refused for existing (that is the caller's
    question: a record to keep, a video to replace).

    Raises:
        OutputError: naming the option, the path, what is wrong and what to do.
    """
    text = str(path)
    if '\0' in text:
        raise OutputError(f'{option} {text!r}: a path cannot hold a NUL character')
    target = Path(os.path.abspath(path))
    existing = target
    for place in [*reversed(target.parents), target]:
        try:
            if not place.exists():
                break
        except PermissionError:
            raise OutputError(f'{option} {path}: this user may not look into {place.parent}: '
                              f'choose another {option}') from None
        except OSError as error:  # a name too long, a loop of links, ...
            raise OutputError(f'{option} {path}: {error.strerror}: choose another '
                              f'{option}') from None
        if place != target and not place.is_dir():
            raise OutputError(f'{option} {path} lies under {place}, which is a file, not a '
                              f'folder: choose another {option}')
        existing = place
    folder = existing if existing.is_dir() else existing.parent
    mount = mount_of(folder)
    if mount is not None and mount[1] in PSEUDO_FILE_SYSTEMS:
        raise OutputError(f'{option} {path} is on {mount[0]}, a {mount[1]} file system (the '
                          "kernel's view of the system, not storage): choose a folder on a "
                          'disk')
    if mount is not None and 'ro' in mount[2]:
        raise OutputError(f'{option} {path} is on {mount[0]}, which is mounted read-only: '
                          f'choose another {option}')
    needed = os.W_OK | os.X_OK
    if not os.access(folder, needed) or (kind == 'file' and existing == target
                                         and not os.access(target, os.W_OK)):
        raise OutputError(f'{option} {path}: this user ({_user()}) may not write in {folder}: '
                          f'choose another {option}, or make it writable')


def _user() -> str:
    """This process's user name (its uid where it has none)."""
    try:
        import pwd
        return pwd.getpwuid(os.getuid()).pw_name
    except (ImportError, KeyError):
        return f'uid {os.getuid()}'
