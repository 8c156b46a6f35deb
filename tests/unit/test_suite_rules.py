"""The suite's own rules (tests/suite.py, the plug-in tests/conftest.py registers), run by a
real pytest on small suites of their own: under CI a test that did not run fails the run and
is named; elsewhere a banner lists it; the shared fixtures of ``ENDED_EARLY`` end after the
last test of their unit that uses them; a module with a module-scoped fixture is one unit of
work, run by one worker."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parents[1]

#: A suite that logs its fixtures' setup and teardown and its tests to events.txt.
CONFTEST = """
import os
import pytest

def log(text):
    with open(os.path.join(os.path.dirname(__file__), 'events.txt'), 'a') as events:
        events.write(text + '\\n')

@pytest.fixture(scope='session')
def browser():
    log('browser up')
    yield
    log('browser down')
"""
SKIPS = """
import pytest

def test_runs():
    pass

def test_needs_a_tool():
    pytest.skip('no chromium: make browser-tools installs it')
"""
SHARES = """
import os

import pytest
from conftest import log

@pytest.fixture(scope='module')
def scenery():
    log(f'scenery on {os.environ.get("PYTEST_XDIST_WORKER", "main")}')
    yield

def test_first(browser, scenery):
    log('first')

def test_second(browser, scenery):
    log('second')

def test_third(scenery):
    log('third')
"""


def run_suite(folder: Path, *args: str, ci: bool) -> subprocess.CompletedProcess:
    """pytest with the suite's plug-in on ``folder`` (its own rootdir), CI set or not."""
    (folder / 'pytest.ini').write_text('[pytest]\n')
    env = {**os.environ, 'PYTHONPATH': os.pathsep.join([str(TESTS), str(folder)]),
           'CI': 'true' if ci else ''}
    env.pop('PYTEST_ADDOPTS', None)  # the outer run's (a junit file of its own)
    env.pop('PYTEST_XDIST_WORKER', None)
    return subprocess.run([sys.executable, '-m', 'pytest', '-p', 'suite', '-p', 'no:cacheprovider',
                           *args], cwd=folder, env=env, capture_output=True, text=True,
                          timeout=120)


@pytest.fixture
def skips(tmp_path: Path) -> Path:
    (tmp_path / 'conftest.py').write_text(CONFTEST)
    (tmp_path / 'test_skips.py').write_text(SKIPS)
    return tmp_path


def test_under_ci_a_skip_fails_the_run_and_is_named(skips):
    done = run_suite(skips, ci=True)
    assert done.returncode == pytest.ExitCode.TESTS_FAILED, done.stdout
    assert '1 passed, 1 skipped' in done.stdout
    assert 'NOT RUN: 1 tests' in done.stdout
    assert 'no chromium: make browser-tools installs it' in done.stdout
    assert 'in test_skips.py' in done.stdout and 'this run FAILS' in done.stdout


def test_outside_ci_a_skip_is_listed_and_passes(skips):
    done = run_suite(skips, ci=False)
    assert done.returncode == pytest.ExitCode.OK, done.stdout
    assert 'NOT RUN: 1 tests' in done.stdout and 'Not a CI run' in done.stdout


def test_under_ci_a_deselected_test_fails_the_run(skips):
    done = run_suite(skips, '-k', 'runs', ci=True)
    assert done.returncode == pytest.ExitCode.TESTS_FAILED, done.stdout
    assert 'deselected (-k, -m or a plug-in)' in done.stdout
    assert run_suite(skips, '-k', 'runs', ci=False).returncode == pytest.ExitCode.OK


def test_a_clean_run_passes_under_ci(tmp_path):
    (tmp_path / 'test_fine.py').write_text('def test_fine():\n    pass\n')
    done = run_suite(tmp_path, ci=True)
    assert done.returncode == pytest.ExitCode.OK, done.stdout
    assert 'NOT RUN' not in done.stdout


@pytest.mark.parametrize('workers', [[], ['-n', '2']], ids=['one process', 'two workers'])
def test_a_shared_fixture_ends_after_the_last_test_of_its_unit_that_uses_it(tmp_path, workers):
    (tmp_path / 'conftest.py').write_text(CONFTEST)
    (tmp_path / 'test_shares.py').write_text(SHARES)
    for k in range(3):  # other units, for the second worker
        (tmp_path / f'test_other_{k}.py').write_text('def test_other():\n    pass\n')
    done = run_suite(tmp_path, *workers, ci=True)
    assert done.returncode == pytest.ExitCode.OK, done.stdout + done.stderr
    events = (tmp_path / 'events.txt').read_text().splitlines()
    # The module (one unit: a module-scoped fixture) on one worker, its fixture made once;
    # the browser down after the second test, not at the session's end after the third.
    assert len([event for event in events if event.startswith('scenery on')]) == 1
    assert [event for event in events if not event.startswith('scenery')] == \
        ['browser up', 'first', 'second', 'browser down', 'third']


class Listed:
    """What :func:`suite.order` reads of a pytest item: its id and its marks (none)."""

    def __init__(self, nodeid: str) -> None:
        self.nodeid = nodeid

    def get_closest_marker(self, name: str) -> None:
        return None


def test_a_shared_runs_modules_run_in_the_listed_order_whatever_the_command_line():
    """``pytest tests/live tests/browser`` collects the live module first; the browser's
    module must still come first (its live test opens the run while the episode runs)."""
    import suite  # tests/, on the path as the conftest's folder

    live = 'tests/live/test_live_node.py::test_seen'
    browser = 'tests/browser/test_node_system.py::test_shown'
    quick = 'tests/unit/test_quick.py::test_quick'
    embedded = 'tests/live/test_live_embedded.py::test_seen'
    items = [Listed(quick), Listed(embedded), Listed(live), Listed(browser)]
    suite.order(items)  # type: ignore[arg-type]
    assert [item.nodeid for item in items] == [browser, live, embedded, quick]
