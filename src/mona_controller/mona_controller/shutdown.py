"""Leaving rclpy without hanging: node teardown under a watchdog.

With the Fast DDS 2.14 of these wheels, destroying the last node (and with it the DDS
participant) can livelock when a discovery callback is in flight, typically while many
processes leave at once: ``DomainParticipant::set_listener`` spins at 100 % CPU, holding the
GIL, forever (eProsima/Fast-DDS#6513). A Python thread cannot interrupt it, so the watchdog is
``faulthandler``'s C thread: if teardown is not done in ``timeout`` seconds it prints where
the process hung and exits with status 1 instead of burning a core until it is killed.
"""

from __future__ import annotations

import faulthandler
import sys
from collections.abc import Iterable

import rclpy
from rclpy.node import Node

#: Wall seconds a clean teardown may take (it normally takes milliseconds).
TEARDOWN_TIMEOUT = 10.0


def teardown(nodes: Iterable[Node | None], timeout: float = TEARDOWN_TIMEOUT) -> None:
    """Destroy ``nodes`` and shut rclpy down; exit with status 1 if that hangs."""
    faulthandler.dump_traceback_later(timeout, exit=True, file=sys.stderr)
    try:
        for node in nodes:
            if node is not None:
                node.destroy_node()
        rclpy.try_shutdown()
    finally:
        faulthandler.cancel_dump_traceback_later()
