"""Every implementation the table names passes the suite: ``make test`` runs the rules on the
default world directly, and here on each other entry of implementations.IMPLEMENTATIONS (so
adding a line there puts it under CI), each in a pytest of its own; and the default world
with a user's controller kind, the plug-in of docs/extending.md, as its controller nodes
(``--params``)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from harness import REPO, recipes
from implementations import IMPLEMENTATIONS
from inner_suite import run_rules_once_more

pytestmark = [pytest.mark.ros, pytest.mark.selftest]

OTHERS = list(IMPLEMENTATIONS)[1:]


@pytest.mark.parametrize('name', OTHERS)
def test_the_implementation_passes_every_rule(name):
    if IMPLEMENTATIONS[name].needs_firmware:
        missing = [tool for tool in ('avr-gcc', 'make', 'cc') if shutil.which(tool) is None]
        if missing or not Path('/usr/include/simavr/sim_avr.h').exists():
            pytest.skip(f'{name} needs {missing or "simavr"}: make firmware-tools')
    # A realtime world does not wait for the suite's scripted robots: on a busy 2-core
    # machine an answer can come later than `absent_after` steps, so a robot the rules need
    # counts absent (they answer from a process of their own, scripted.py, not behind the
    # probe's records, but a machine can be busier still). So after any failure one more
    # run, which must pass; a failure shows the first run's failures with the second's.
    first, result = run_rules_once_more('--world-cmd', name, timeout=600,
                                        after_any_failure=IMPLEMENTATIONS[name].mode == 'realtime')
    assert result.returncode == 0, first + result.stdout[-4000:] + result.stderr[-2000:]
    assert ' passed' in result.stdout.splitlines()[-1]


def test_a_users_controller_kind_passes_every_rule(tmp_path: Path):
    files, _ = recipes((REPO / 'docs' / 'extending.md').read_text())
    (tmp_path / 'shy.py').write_text(files['my_swarm/shy.py'])
    params = tmp_path / 'params.yaml'
    params.write_text('/**:\n  ros__parameters:\n    plugins: [shy.py]\n'
                      '    controller: {kind: shy}\n')
    first, result = run_rules_once_more(
        '--params', str(params), '--basetemp', str(tmp_path / 'run'), timeout=600)
    assert result.returncode == 0, first + result.stdout[-4000:] + result.stderr[-2000:]
    assert ' passed' in result.stdout.splitlines()[-1]
    logs = list((tmp_path / 'run').rglob('controllers.log'))  # the kind the nodes ran
    assert logs and all('start 0 ns, active (shy)' in log.read_text() for log in logs), logs
