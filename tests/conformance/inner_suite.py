"""Run the rules (test_interfaces.py) in a pytest of their own, as the self-tests do."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def run_rules(*args: str, timeout: float) -> subprocess.CompletedProcess:
    """The rules against what ``args`` name (``--world-cmd``, ``--params``...), quietly, with
    failures listed (-rfE). The outer run's PYTEST_ADDOPTS is not passed on: a
    ``--junitxml`` there would have the inner run overwrite the outer run's report."""
    env = {key: value for key, value in os.environ.items() if key != 'PYTEST_ADDOPTS'}
    command = [sys.executable, '-m', 'pytest', str(HERE / 'test_interfaces.py'), '-q', '-rfE',
               '-p', 'no:cacheprovider', *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout,
                          cwd=HERE.parents[1], env=env)
