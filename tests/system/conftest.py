"""Fixtures of the system tests (helpers in tests/swarmrun.py)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from swarmrun import SwarmRun


@pytest.fixture
def swarm(tmp_path: Path) -> Iterator[Callable[..., SwarmRun]]:
    """``swarm(*args, out=name)`` starts scripts/swarm.sh; everything is cleaned up after."""
    runs: list[SwarmRun] = []

    def start(*args: str, out: str = 'run') -> SwarmRun:
        runs.append(SwarmRun(tmp_path / out, list(args)))
        return runs[-1]

    try:
        yield start
    finally:
        for run in runs:
            run.stop()
