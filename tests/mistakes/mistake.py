"""The machinery of the mistakes table (tests/mistakes/test_mistakes.py): one mistake is a
command a user might type, the exit status and the message it must give, and the folders
whose bytes must not change when it refuses.

Each area keeps its rows in its own module (``cases_*.py``, a list named ``CASES``); the
table is their sum. A row's command runs as a real process (``mona-swarm`` from the venv,
or ``scripts/swarm.sh``) in a scratch folder prepared by its ``setup``.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent
MONA_SWARM = str(BIN / 'mona-swarm')
SWARM_SH = str(REPO / 'scripts' / 'swarm.sh')


@dataclass(frozen=True)
class Mistake:
    """One row: ``command`` (``{tmp}`` and ``{repo}`` are filled in) run in a scratch folder
    that ``setup(tmp)`` prepared; the exit status, a regex its stderr+stdout must match, and
    the folders (relative to tmp) that must be byte-identical before and after when it
    refuses (status 2)."""

    name: str
    command: list[str]  # ``env`` values are filled in alike
    status: int
    pattern: str
    setup: Callable[[Path], None] | None = None
    unchanged: tuple[str, ...] = ()
    env: dict[str, str] = field(default_factory=dict)
    timeout: float = 120.0

    def argv(self, tmp: Path) -> list[str]:
        return [part.format(tmp=tmp, repo=REPO) for part in self.command]


def folder_digest(folder: Path) -> str:
    """A hash of every file's relative path and bytes under ``folder`` ('' if absent)."""
    if not folder.exists():
        return ''
    digest = hashlib.sha256()
    for path in sorted(p for p in folder.rglob('*') if p.is_file()):
        digest.update(str(path.relative_to(folder)).encode() + b'\0')
        digest.update(hashlib.sha256(path.read_bytes()).digest())
    return digest.hexdigest()


def run_mistake(mistake: Mistake, tmp: Path) -> subprocess.CompletedProcess:
    """Run one row's command as a user would, with the venv first on PATH."""
    env = dict(os.environ, PATH=f'{BIN}{os.pathsep}{os.environ.get("PATH", "")}',
               **{name: value.format(tmp=tmp, repo=REPO) for name, value in mistake.env.items()})
    return subprocess.run(mistake.argv(tmp), cwd=tmp, env=env, capture_output=True,
                          text=True, timeout=mistake.timeout)
