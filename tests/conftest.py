"""Shared fixtures for tests that run ROS: a private domain and processes that never outlive
the test (the machinery is in tests/harness.py).

- ``ros_env``: a private ``ROS_DOMAIN_ID`` (locked, so parallel pytest runs and
  scripts/swarm.sh never share one), the Fast DDS localhost profile, the venv on PATH. The
  mapping is the environment for subprocesses; it is also applied to ``os.environ`` for the
  test, so in-process ``rclpy.init()`` joins the same domain.
- ``processes``: ``processes.spawn(cmd, name)`` starts a command in its own process group,
  logging to ``tmp_path/<name>.log``; at teardown every group gets the launcher's signal
  ladder (SIGINT, SIGTERM, SIGABRT, SIGKILL), and Fast DDS shared-memory files created
  meanwhile and used by no process are removed.
- ``busy_cores``: every core kept busy by spinning processes for the test's duration, as on a
  shared CI machine (races that a quiet machine hides show up there).
- ``embedded_live``, ``node_live``: the lingering live runs of the embedded runner and of the
  node system that the live and the browser tiers look at, once per pytest process
  (tests/liverun.py; the modules using each are one unit of work: tests/suite.py).

The suite's own rules (tests/README.md says how to write a test that keeps them):

- Never skip silently: under ``CI=true`` a skipped or deselected test fails the run, listing
  each with its reason; elsewhere the run ends with a banner of what did not run and the
  command that installs what it lacked.
- Numba's cache is warm before the workers start: with pytest-xdist, the controller compiles
  (or loads) every cached kernel once, serially, before it spawns them
  (``swarm_supervisor.engine.warm``; workers compiling the same kernel at once can leave a
  cache that crashes them, docs/architecture.md "Numba's cache").
- Parallel by default (``make test`` runs pytest-xdist): every pytest process holds a ROS
  domain of its own for the session (in ``os.environ``), so a node started without
  ``ros_env`` still meets no other test's; ports a test names come from
  ``harness.free_port()``. A module with a module-scoped fixture, and the modules sharing a
  session-scoped run, are one unit of work each (one worker), and the units that take
  longest are handed out first (tests/suite.py).
"""

from __future__ import annotations

import signal
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from swarm_supervisor.system.processes import busy_cores as busy_loops

import suite
from harness import Processes, private_domain, ros_environment


@pytest.fixture
def ros_env(monkeypatch: pytest.MonkeyPatch) -> Iterator[dict[str, str]]:
    """A private ROS domain: the environment for subprocesses, also set in os.environ."""
    with private_domain() as domain:
        env = ros_environment(domain)
        for key in ('ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_LOCALHOST_ONLY'):
            monkeypatch.delenv(key, raising=False)
        for key in ('ROS_DOMAIN_ID', 'RMW_IMPLEMENTATION', 'FASTRTPS_DEFAULT_PROFILES_FILE'):
            monkeypatch.setenv(key, env[key])
        yield env


@pytest.fixture
def processes(ros_env: dict[str, str], tmp_path: Path) -> Iterator[Processes]:
    """Start processes in the test's ROS domain; all are stopped and cleaned up afterwards."""
    group = Processes(ros_env, tmp_path)
    try:
        yield group
    finally:
        group.stop_all()


@pytest.fixture
def busy_cores() -> Iterator[None]:
    """Every core busy for the duration of the test (bounded, stopped afterwards)."""
    with busy_loops():
        yield


@pytest.fixture(scope='session')
def embedded_live(tmp_path_factory: pytest.TempPathFactory) -> Iterator:
    """The embedded runner's live run the live and browser tiers share (tests/liverun.py)."""
    from liverun import embedded_live_run
    yield from embedded_live_run(tmp_path_factory)


@pytest.fixture(scope='session')
def node_live(tmp_path_factory: pytest.TempPathFactory) -> Iterator:
    """The node system's live run the live and browser tiers share (tests/liverun.py)."""
    from liverun import node_live_run
    yield from node_live_run(tmp_path_factory)


@pytest.fixture
def executor(ros_env: dict[str, str]) -> Iterator:
    """An initialised rclpy context (private domain) with one executor; all torn down after
    (the node-level tests of tests/ros and tests/driver)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    context = rclpy.Context()
    rclpy.init(context=context, domain_id=int(ros_env['ROS_DOMAIN_ID']))
    executor = SingleThreadedExecutor(context=context)
    try:
        yield executor
    finally:
        for node in executor.get_nodes():
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()
        rclpy.try_shutdown(context=context)


@pytest.fixture
def spin_until(executor) -> Callable[..., None]:
    """``spin_until(condition, timeout, what)``: spin the executor until condition() holds."""
    import time

    def spin(condition: Callable[[], bool], timeout: float = 30.0, what: str = '') -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < deadline, f'timed out after {timeout} s: {what}'
            executor.spin_once(timeout_sec=0.05)

    return spin


# --- the suite's rules (tests/suite.py) -------------------------------------------------------

#: What pytest_sessionstart's warm step did, for the header.
WARMED = pytest.StashKey[str]()
#: The environment a ROS domain is: set for the whole session from this process's own domain.
DOMAIN_KEYS = ('ROS_DOMAIN_ID', 'RMW_IMPLEMENTATION', 'FASTRTPS_DEFAULT_PROFILES_FILE')


@pytest.fixture(scope='session', autouse=True)
def session_domain() -> Iterator[int]:
    """This pytest process's own ROS domain, in os.environ for the session (``ros_env`` gives
    a test its own on top)."""
    with private_domain() as domain, pytest.MonkeyPatch.context() as patch:
        env = ros_environment(domain)
        for key in DOMAIN_KEYS:
            patch.setenv(key, env[key])
        for key in ('ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_LOCALHOST_ONLY', 'ROS_STATIC_PEERS'):
            patch.delenv(key, raising=False)
        yield domain


def pytest_configure(config: pytest.Config) -> None:
    """Ctrl-C as a terminal gives it, whoever started the suite: a command started with ``&``
    by a script (a non-interactive shell, as a CI runner may do) inherits SIGINT ignored, and
    so would every process the tests start, so a test's Ctrl-C to a study, an evolution or a
    live run would be lost (they run on). The tests play a user at a terminal: restore
    Python's own handler here (in the controller and each worker), and the processes the
    tests start inherit the default."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    # The suite's own rules and schedule (tests/suite.py: a plug-in, so that a test can run
    # them on a suite of its own, tests/unit/test_suite_rules.py).
    if not config.pluginmanager.is_registered(suite):
        config.pluginmanager.register(suite, 'suite')


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist's, which spawns the workers
def pytest_sessionstart(session: pytest.Session) -> None:
    """On the controller of a pytest-xdist run: numba's cache warmed, serially (a few seconds
    once cached; the header says how long). A kernel that fails to compile here fails its
    tests later, where the error is reported."""
    config = session.config
    if hasattr(config, 'workerinput') or not config.pluginmanager.has_plugin('dsession'):
        return
    from swarm_supervisor.engine.warm import warm_kernels
    try:
        config.stash[WARMED] = str(warm_kernels())
    except Exception as error:  # reported in the header; the tests go on
        config.stash[WARMED] = f'not warmed ({type(error).__name__}: {error})'


def pytest_report_header(config: pytest.Config) -> str | None:
    """What the controller's warm step did (pytest_sessionstart)."""
    return f'numba cache: {config.stash[WARMED]}' if WARMED in config.stash else None
