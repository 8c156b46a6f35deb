"""The suite's own machinery, a pytest plug-in (tests/conftest.py registers it; tests/README.md
has the rules): how pytest-xdist cuts the suite into units of work and in which order it hands
them out, which shared fixtures end early, and what a run did not run (under CI it fails).
tests/unit/test_suite_rules.py runs it on small suites of its own.

Units: the tests of one module run on one worker when the module, or a conftest.py beside it,
defines a module-, class- or package-scoped fixture (made once, not once per worker), and the
modules of :data:`SHARED_RUNS` run together, on one worker, as one unit (they look at one
session-scoped run); every other test is a unit of its own. pytest-xdist's ``loadgroup`` would
do this from ``xdist_group`` marks, but with the pinned pytest 9.2 it silently groups nothing
(it renames test ids pytest 9.2 no longer reads: pytest-dev/pytest-xdist#1386), so the units are
computed here from the ids and the modules' source, on the controller, by a scheduler of our
own (``pytest_xdist_make_scheduler``).

Order: units are handed out in the order the workers collect the tests, which
:func:`order` sorts: the shared runs first, then modules with a test marked ``slow``, then
modules that start nodes (``ros``), then the rest; a module's tests stay in their order.
"""

from __future__ import annotations

import functools
import os
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from xdist.scheduler import LoadScopeScheduling

#: Modules that look at one session-scoped run, by the run's fixture, longest first: each
#: group is one unit of work (tests/liverun.py, tests/conformance/conftest.py's ``run``), its
#: modules run in the order listed.
SHARED_RUNS = {
    'node_live': ('tests/browser/test_node_system.py', 'tests/live/test_live_node.py'),
    'embedded_live': ('tests/browser/test_embedded.py', 'tests/live/test_live_embedded.py'),
    'conformance': ('tests/conformance/test_interfaces.py',),
}
SHARED_MODULES = {module: run for run, modules in SHARED_RUNS.items() for module in modules}
#: A fixture made once for a module (or wider): its tests must not be spread over workers.
WIDE_FIXTURE = re.compile(r"""scope\s*=\s*['"](module|class|package)['"]""")
#: Unit ranks: what takes longest is handed out first.
SHARED, SLOW, ROS, QUICK = range(4)


def in_ci() -> bool:
    """Whether this is a CI run (CI set, as CI services do, and not to false)."""
    return os.environ.get('CI', '').strip().lower() not in ('', '0', 'false', 'no')


def module_of(nodeid: str) -> str:
    return nodeid.split('::')[0]


@functools.cache
def has_wide_fixture(root: Path, module: str) -> bool:
    """Whether ``module`` or a conftest.py of its folder defines a module-scoped fixture."""
    for path in (root / module, (root / module).parent / 'conftest.py'):
        try:
            if WIDE_FIXTURE.search(path.read_text(errors='replace')):
                return True
        except OSError:
            continue
    return False


def unit_of(root: Path, nodeid: str) -> str:
    """The unit of work of test ``nodeid``: its shared run, its module, or itself."""
    module = module_of(nodeid)
    if module in SHARED_MODULES:
        return SHARED_MODULES[module]
    return module if has_wide_fixture(root, module) else nodeid


class SuiteScheduling(LoadScopeScheduling):
    """pytest-xdist's scope scheduling over the units of :func:`unit_of`."""

    def _split_scope(self, nodeid: str) -> str:
        return unit_of(self.config.rootpath, nodeid)


def rank(item: pytest.Item) -> int:
    if module_of(item.nodeid) in SHARED_MODULES:
        return SHARED
    if item.get_closest_marker('slow'):
        return SLOW
    return ROS if item.get_closest_marker('ros') else QUICK


def shared_place(module: str) -> tuple[int, int]:
    """(its run's place in :data:`SHARED_RUNS`, its place among that run's modules); (0, 0)
    for a module of no shared run."""
    if module not in SHARED_MODULES:
        return 0, 0
    run = SHARED_MODULES[module]
    return list(SHARED_RUNS).index(run), SHARED_RUNS[run].index(module)


def order(items: list[pytest.Item]) -> None:
    """Sort ``items`` so that the units that take longest come first (a module's tests stay
    together, in their order; the shared runs in :data:`SHARED_RUNS`' order, and a run's
    modules in the order listed there, whatever order the command line gave: the browser's
    live test must open its run while the episode runs)."""
    module_rank: dict[str, tuple[int, int, int]] = {}
    for item in items:
        module = module_of(item.nodeid)
        module_rank[module] = min(module_rank.get(module, (QUICK, 0, 0)),
                                  (rank(item), *shared_place(module)))
    items.sort(key=lambda item: module_rank[module_of(item.nodeid)])


#: Session fixtures ended once the last test of a unit that uses them is over, not when the
#: session ends: the lingering live runs (their processes would serve a view nobody looks at
#: for the rest of the session) and the browser (tests/conftest.py's teardown hook).
ENDED_EARLY = ('embedded_live', 'node_live', 'browser')


def ended_after(item: pytest.Item) -> list[str]:
    """The :data:`ENDED_EARLY` fixtures ``item`` uses and no later test of its unit does (a
    unit runs on one worker, in the session's order)."""
    used = [name for name in ENDED_EARLY if name in getattr(item, 'fixturenames', ())]
    if not used:
        return []
    items = item.session.items
    root = item.config.rootpath
    unit = unit_of(root, item.nodeid)
    later = items[items.index(item) + 1:]
    wanted = set().union(*(getattr(other, 'fixturenames', ()) for other in later
                           if unit_of(root, other.nodeid) == unit))
    return [name for name in used if name not in wanted]


def not_run(config: pytest.Config) -> tuple[list, list]:
    """(skipped reports, deselected items) of the session so far."""
    reporter = config.pluginmanager.get_plugin('terminalreporter')
    if reporter is None:
        return [], []
    return reporter.stats.get('skipped', []), reporter.stats.get('deselected', [])


def skip_reason(report: pytest.TestReport | pytest.CollectReport) -> str:
    longrepr = report.longrepr
    reason = longrepr[2] if isinstance(longrepr, tuple) else str(longrepr)
    return reason.removeprefix('Skipped: ')


def write_banner(terminalreporter, config: pytest.Config) -> None:
    """What did not run: each skip's reason (which names the command that installs what was
    missing), with its count and modules; under CI also what was deselected."""
    skipped, deselected = not_run(config)
    if not in_ci():
        deselected = []  # a choice of the one who ran it (-k, -m)
    if not skipped and not deselected:
        return
    reasons: dict[str, list[str]] = {}
    for report in skipped:
        reasons.setdefault(skip_reason(report), []).append(module_of(report.nodeid))
    if deselected:
        reasons['deselected (-k, -m or a plug-in)'] = [module_of(item.nodeid)
                                                       for item in deselected]
    count = sum(len(modules) for modules in reasons.values())
    terminalreporter.section(f'NOT RUN: {count} tests', sep='=', red=in_ci(),
                             yellow=not in_ci(), bold=True)
    for reason, modules in sorted(reasons.items(), key=lambda kv: -len(kv[1])):
        terminalreporter.write_line(f'{len(modules):4d}  {reason}')
        terminalreporter.write_line(f'      in {", ".join(sorted(set(modules)))}')
    terminalreporter.write_line(
        'CI=true: this run FAILS for them (a test that did not run is not a pass).' if in_ci()
        else 'Not a CI run, so they are only listed here; under CI=true they fail the run.')


# --- the hooks (tests/conftest.py registers this module as a plug-in) ---------------------

@pytest.hookimpl(wrapper=True, trylast=True)
def pytest_runtest_teardown(item: pytest.Item, nextitem: pytest.Item | None) -> Iterator[None]:
    """End the session fixtures of :data:`ENDED_EARLY` that ``item`` was the last test
    of its unit to use (their teardown's checks then fail this test's teardown, as they would
    the last test's)."""
    result = yield
    # pytest has no public call to end one fixture early: FixtureDef.finish is what the
    # session's own teardown calls (pytest 9.2, pinned), and a later request makes it anew.
    for name in ended_after(item):
        for fixturedef in item._fixtureinfo.name2fixturedefs.get(name, ()):  # type: ignore[attr-defined]
            fixturedef.finish(item._request)  # type: ignore[attr-defined]
    return result


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The units that take longest first (order)."""
    order(items)


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist's own choice
def pytest_xdist_make_scheduler(config: pytest.Config, log):
    """Our units of work (SuiteScheduling), unless ``--dist each`` asks otherwise."""
    return None if config.getvalue('dist') == 'each' else SuiteScheduling(config, log)


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """Under CI a test that did not run fails the run (the summary lists them)."""
    if hasattr(session.config, 'workerinput') or not in_ci():
        return
    if any(not_run(session.config)) and session.exitstatus == pytest.ExitCode.OK:
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


def pytest_terminal_summary(terminalreporter, exitstatus: int, config: pytest.Config) -> None:
    """The banner of what did not run (write_banner)."""
    write_banner(terminalreporter, config)
