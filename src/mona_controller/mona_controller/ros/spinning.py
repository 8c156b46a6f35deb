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

import ctypes
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
    except BaseException:
        _never_destroy(executor)
        raise
    finally:
        for node in nodes:
            executor.remove_node(node)


def _never_destroy(executor: Executor) -> None:
    """Keep an executor that an exception left in its middle alive until the process ends.

    A signal raises (KeyboardInterrupt) or shuts the context down from another thread (then
    ``RCLError``: making a new entity's wait set needs a valid context). If that happens while
    the executor takes in an entity created since its last update (the controller subscribes
    from a timer), the entity's callback stays registered, and the executor's destructor
    aborts the whole process ("Destroying callback manager with callbacks remaining", rclpy
    7.1.5's ``RclCallbackManager``) or terminates it (a Python error thrown in the
    destructor), before the node could close its outputs. Signalled just after a subscription,
    3 of 60 probes aborted after SIGTERM on 2 busy cores, 5 of 60 after SIGINT. An exception
    here ends the node, so one executor's memory is the cheaper loss.
    """
    ctypes.pythonapi.Py_IncRef(ctypes.py_object(executor))
