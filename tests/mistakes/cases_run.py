"""Mistakes with ``mona-swarm run``, ``analyze``, ``recover`` and ``animate``."""

from __future__ import annotations

from pathlib import Path

from mistake import MONA_SWARM, Mistake


def earlier_run(tmp: Path) -> None:
    """A folder holding an earlier embedded run (a tiny one)."""
    import subprocess
    subprocess.run([MONA_SWARM, 'run', '--population', '3', '--duration', '2',
                    '--out', str(tmp / 'earlier')], check=True, capture_output=True)


CASES = [
    Mistake('run-over-a-run', [MONA_SWARM, 'run', '--population', '3', '--duration', '2',
                               '--out', '{tmp}/earlier'],
            2, r'earlier.*holds.*--overwrite', setup=earlier_run, unchanged=('earlier',)),
    Mistake('run-population-too-large', [MONA_SWARM, 'run', '--population', '2000',
                                         '--out', '{tmp}/new'],
            2, r'does not fit', unchanged=('new',)),
]
