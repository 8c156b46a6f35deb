"""Leaving rclpy without hanging, with the exit status the node meant.

With the Fast DDS 2.14 of these wheels, destroying DDS entities while many peers leave at the
same moment (the end of a 50-robot run) can hang for good, with the GIL held, in one of two
known ways, both seen in ``bench/teardown_storm.py`` with gdb:

- eProsima/Fast-DDS#6513: rmw's ``destroy_participant`` (the last ``destroy_node``) calls
  ``DomainParticipant::set_listener(nullptr)``, which takes the participant's mutex and
  busy-waits for in-flight discovery callbacks; one was in flight, waiting for that mutex.
- eProsima/Fast-DDS#6502: a DataWriter or DataReader destructor (``destroy_publisher`` ...)
  waits in ``ResourceEvent::unregister_timer`` for the event thread, which waits in
  ``PDP::check_remote_participant_liveliness`` for the PDP mutex, held by a receive thread
  that removes a leaving peer's endpoint and waits in ``unregister_timer`` too.

No Python thread can run then, so only native code can end such a process. That used to be
``faulthandler``'s watchdog, which can only exit with status 1, and ``scripts/swarm.sh`` then
reported a node FAILED whose results were complete.

A node whose last messages others need (the world's final status and state) calls
:func:`deliver` first, on its normal way out: it waits (``DELIVERY_TIMEOUT`` s at most, in
all) until every reliable publisher of the node has its messages acknowledged by every reader
it is matched with. A reliable writer resends a lost sample only while it lives, and on a busy
machine UDP datagrams are lost (a full receive buffer: the kernel's ``RcvbufErrors``): the
world used to publish its final ``/world/status`` and leave a second later on the shutdown
announcement, and a live node that had lost that datagram served "running" for ever.

The contract of :func:`teardown`: the caller has flushed and closed every output of the node
(files, bags) and knows its exit status; teardown is the last thing ``main()`` does before
it returns that status. Then a hang in DDS cannot lose anything, and the process ends with
that status on every path:

- teardown finishes (the normal case): it returns and ``main()`` returns the status;
- teardown hangs for ``timeout`` seconds: ``faulthandler``'s C thread writes every thread's
  Python stack to stderr (where it hung stays in the log), and ``DUMP_GRACE`` seconds later a
  POSIX timer thread calls ``_exit(exit_status)``: ``timer_create`` with ``SIGEV_THREAD`` and
  libc's ``_exit`` itself as the notify function, the status as its argument. Neither needs
  the GIL. ``_exit`` runs no atexit handlers and flushes no Python buffers, hence the
  contract; teardown flushes ``sys.stdout`` and ``sys.stderr`` itself. rcl's own log file
  (``ROS_LOG_DIR``, flushed by spdlog every few seconds) may lose its last lines; the console
  copy in the node's log does not.

Measured with ``bench/teardown_storm.py`` (50 controller-shaped processes and a world leaving
at the same instant, watchdog 10 s, 2-core machine shared with other test suites; "lease 5 s"
is a stress profile that checks peers' liveliness 4 times as often)::

    teardown                  rounds  processes  hung  rounds with a hang  exit statuses
    before (faulthandler)     16      816        2     2                   0 x814, 1 x2
      lease 5 s               7       357        2     2                   0 x355, 1 x2
    rclpy.shutdown first      3       153        0     0                   0 x153
    entities one by one       3       153        0     0                   0 x153
    no DDS destruction        3       153        0     0                   0 x153
    this one                  9       459        2     2                   0 x459
      lease 5 s               7       357        4     3                   0 x357

11 of the rounds before ran with a 30 or 60 s watchdog: the hang seen there still held after
30 s. A clean teardown took 3.7 - 4.9 s (median per run), at most 5.8 s, for every variant
that destroys entities (51 processes at once on 2 cores), 0.2 s for none; a hung one now
ended at 11.05 - 11.64 s with its stack in the log and status 0 (before: status 1 at 10 s).

Why not avoid the hang instead: both deadlocks are between Fast DDS's own threads, reached by
the first entity destroyed while peers leave. rclpy's ``destroy_node`` already destroys
publishers, subscriptions, services and timers before the node, and shutting the context down
first changes nothing (the participant goes with the last node either way); no ordering of
ours stops the peers' discovery traffic. At about one hang in 8 rounds, 3 rounds of each
ordering cannot tell them apart from before, and the stacks give no reason to expect a
difference. No profile setting is documented to avoid either deadlock (the shorter lease made
hangs more frequent: 6 in 14 rounds against 4 in 31). Skipping DDS destruction altogether
(``os._exit`` at once) never hung and is fast, but then peers learn that the process left only
when its lease (20 s) expires, rcl's log file is not flushed, and no stack tells that Fast DDS
would have hung; so teardown still destroys everything and only bounds how long that may take.

Without ``timer_create`` (not glibc) the watchdog falls back to faulthandler's exit with
status 1.
"""

from __future__ import annotations

import contextlib
import ctypes
import faulthandler
import gc
import sys
import time
from collections.abc import Iterable

import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

#: Wall seconds a clean teardown may take before the stack is dumped: well under a second for
#: one process, at most 5.8 s measured for each of 51 processes leaving together on 2 cores.
TEARDOWN_TIMEOUT = 10.0
#: Seconds between the stack dump and the exit: faulthandler writes the stack in
#: milliseconds, but its thread competes for a core with every spinning process.
DUMP_GRACE = 1.0
#: Wall seconds, in all, :func:`deliver` waits: a lost sample is resent after the writer's
#: next heartbeat (every 3 s, Fast DDS's default heartbeat period) and the reader's answer.
DELIVERY_TIMEOUT = 4.0

_CLOCK_MONOTONIC = 1
_SIGEV_THREAD = 2


class _Sigevent(ctypes.Structure):
    """glibc's ``struct sigevent`` (64 bytes) with the ``SIGEV_THREAD`` member of the union."""

    _fields_ = [('sigev_value', ctypes.c_void_p),  # union sigval: the argument of _exit
                ('sigev_signo', ctypes.c_int),
                ('sigev_notify', ctypes.c_int),
                ('sigev_notify_function', ctypes.c_void_p),
                ('sigev_notify_attributes', ctypes.c_void_p),
                ('_pad', ctypes.c_int * 8)]


class _Timespec(ctypes.Structure):
    _fields_ = [('tv_sec', ctypes.c_long), ('tv_nsec', ctypes.c_long)]


class _Itimerspec(ctypes.Structure):
    _fields_ = [('it_interval', _Timespec), ('it_value', _Timespec)]


class ExitTimer:
    """A one-shot POSIX timer whose expiry calls ``_exit(status)`` on a new native thread.

    The thread is glibc's (``SIGEV_THREAD``) and runs libc's ``_exit`` itself, so it works
    while another thread holds the GIL forever. ``armed`` is False where ``timer_create`` is
    missing; :meth:`cancel` is then a no-op.
    """

    def __init__(self, seconds: float, status: int) -> None:
        self._timer = ctypes.c_void_p()
        self.armed = False
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            if not hasattr(libc, 'timer_create'):  # glibc < 2.34 has it in librt
                libc = ctypes.CDLL('librt.so.1', use_errno=True)
            event = _Sigevent(sigev_notify=_SIGEV_THREAD,
                              sigev_notify_function=ctypes.cast(libc._exit,
                                                                ctypes.c_void_p).value,
                              sigev_value=status or None)
            if libc.timer_create(_CLOCK_MONOTONIC, ctypes.byref(event),
                                 ctypes.byref(self._timer)) != 0:
                return
            whole = int(seconds)
            expiry = _Itimerspec(it_value=_Timespec(whole, int((seconds - whole) * 1e9)))
            if libc.timer_settime(self._timer, 0, ctypes.byref(expiry), None) != 0:
                libc.timer_delete(self._timer)
                return
        except (OSError, AttributeError):
            return
        self._libc = libc
        self.armed = True

    def cancel(self) -> None:
        """Disarm and delete the timer (before it fired, or the process is gone anyway)."""
        if self.armed:
            self._libc.timer_delete(self._timer)
            self.armed = False


def deliver(nodes: Iterable[Node], seconds: float = DELIVERY_TIMEOUT) -> bool:
    """Wait until every reliable publisher of ``nodes`` has its messages acknowledged by the
    readers it is matched with (True), or ``seconds`` pass in all, or SIGINT (False: the
    node goes on to leave, with the exit status it had)."""
    deadline = time.monotonic() + seconds
    try:
        for node in nodes:
            for publisher in node.publishers:
                left = deadline - time.monotonic()
                if left <= 0 or not publisher.wait_for_all_acked(Duration(seconds=left)):
                    return False
    except KeyboardInterrupt:
        return False
    return True


def teardown(nodes: Iterable[Node | None], timeout: float = TEARDOWN_TIMEOUT, *,
             exit_status: int = 0) -> None:
    """Destroy ``nodes`` and shut rclpy down; if that hangs, end the process with
    ``exit_status`` after writing every thread's stack to stderr.

    Call it last in ``main()``, once every output is flushed and closed, with the status
    ``main()`` is about to return (the process then leaves without a last garbage collection:
    ``gc.freeze()``). It returns when the teardown finishes within ``timeout``
    seconds (then the caller returns ``exit_status`` as before); otherwise it never returns:
    the stack is dumped after ``timeout`` s and the process ends with ``exit_status`` after
    ``timeout + DUMP_GRACE`` s, without running atexit handlers.
    """
    if not 0 <= exit_status <= 255:
        raise ValueError(f'exit_status must be in 0..255, got {exit_status}')
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):  # a closed or broken stream must not stop us
            stream.flush()
    exit_timer = ExitTimer(timeout + DUMP_GRACE, exit_status)
    # Without the timer, faulthandler's own exit (status 1) is the only way out of a hang.
    faulthandler.dump_traceback_later(timeout, exit=not exit_timer.armed, file=sys.stderr)
    try:
        for node in nodes:
            if node is not None:
                node.destroy_node()
        rclpy.try_shutdown()
    finally:
        faulthandler.cancel_dump_traceback_later()
        exit_timer.cancel()
    # The interpreter's last garbage collection, over every object of the node's imports,
    # took 3 s of a node's exit at load 40 (0.5 s with this): a node stopped by SIGINT must
    # be gone before the launcher's SIGTERM 6 s later. Only cyclic garbage is left uncollected,
    # and the caller has closed every output.
    gc.freeze()


#: What a signal raises out of a spinning executor: KeyboardInterrupt (SIGINT),
#: ExternalShutdownException (rclpy's handler shut the context down), or RCLError "the given
#: context is not valid" when that shutdown lands between the executor's check of the context
#: and its wait set (seen on SIGTERM on a busy machine: the metrics node ended with a
#: traceback). Catch it with :func:`raise_unless_stopped`.
STOPPED = (KeyboardInterrupt, ExternalShutdownException, RCLError)


def raise_unless_stopped(error: BaseException) -> None:
    """Re-raise ``error`` (one of :data:`STOPPED`) unless a shutdown explains it: an RCLError
    while the context is still up is a real error."""
    if isinstance(error, RCLError) and rclpy.ok():
        raise error
