"""Every implementation the table names passes the suite: ``make test`` runs the rules on the
default world directly, and here on each other entry of implementations.IMPLEMENTATIONS (so
adding a line there puts it under CI), each in a pytest of its own."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from implementations import IMPLEMENTATIONS

pytestmark = [pytest.mark.ros, pytest.mark.selftest]

HERE = Path(__file__).resolve().parent
OTHERS = list(IMPLEMENTATIONS)[1:]


@pytest.mark.parametrize('name', OTHERS)
def test_the_implementation_passes_every_rule(name):
    if IMPLEMENTATIONS[name].needs_firmware:
        missing = [tool for tool in ('avr-gcc', 'make', 'cc') if shutil.which(tool) is None]
        if missing or not Path('/usr/include/simavr/sim_avr.h').exists():
            pytest.skip(f'{name} needs {missing or "simavr"}: make firmware-tools')
    result = subprocess.run(
        [sys.executable, '-m', 'pytest', str(HERE / 'test_interfaces.py'), '-q', '-rfE',
         '-p', 'no:cacheprovider', '--world-cmd', name],
        capture_output=True, text=True, timeout=600, cwd=HERE.parents[1])
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr[-2000:]
    assert ' passed' in result.stdout.splitlines()[-1]
