"""How the node processes spin: rclpy's events executor, in one place.

The system's nodes exchange several small messages per robot and step; with the
``SingleThreadedExecutor`` most of their CPU went to rebuilding and waiting on the wait set
(py-spy: 47 % of all samples of a 10-robot run inside ``wait_for_ready_callbacks``). rclpy's
``EventsExecutor`` (``rclpy.experimental``, in Jazzy's rclpy 7.1) queues ready entities in C++
and calls only their callbacks: the same 10 robots x 30 s lockstep episode cost 34-45 CPU-s
with the wait-set executor and 23-28 CPU-s with this one in the world, the controllers and the
metrics node, with the same bits (bench/bench_lockstep.py measures the rate).

Callbacks run in the order their messages arrived, which for one publisher's topics is the
order it published them (the world relies on a controller's state and cleaner coming before
its command, as the wait-set executor's order gave).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

from rclpy.executors import Executor
from rclpy.experimental.events_executor import EventsExecutor
from rclpy.node import Node

#: Longest wait for an event before ``done`` is asked again (s). ``spin_once()`` without a
#: timeout can block for good even while timers fire.
POLL = 1.0


def spin_until(nodes: Iterable[Node], done: Callable[[], bool]) -> None:
    """Run the callbacks of ``nodes`` until ``done()`` is true (asked after every callback and
    at least every ``POLL`` s). Signals raise out of it as from ``rclpy.spin``."""
    executor: Executor = EventsExecutor()
    nodes = list(nodes)
    for node in nodes:
        executor.add_node(node)
    try:
        while not done():
            executor.spin_once(timeout_sec=POLL)
    finally:
        for node in nodes:
            executor.remove_node(node)
