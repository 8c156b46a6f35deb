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
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from swarm_supervisor.system.processes import busy_cores as busy_loops

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
