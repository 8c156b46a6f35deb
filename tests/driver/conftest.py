"""Fixtures of the driver's node-level tests: rclpy in this process, in the test's private
domain (the same two as tests/ros/conftest.py, which pytest does not share across folders)."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor


@pytest.fixture
def executor(ros_env: dict[str, str]) -> Iterator[SingleThreadedExecutor]:
    """An initialised rclpy context (private domain) with one executor; all torn down after."""
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
def spin_until(executor: SingleThreadedExecutor) -> Callable[..., None]:
    """``spin_until(condition, timeout, what)``: spin the executor until condition() holds."""

    def spin(condition: Callable[[], bool], timeout: float = 30.0, what: str = '') -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            assert time.monotonic() < deadline, f'timed out after {timeout} s: {what}'
            executor.spin_once(timeout_sec=0.05)

    return spin
