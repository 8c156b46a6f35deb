"""StopRequest (swarm_supervisor.study.interrupt): a signal whose exception Python swallowed
(raised inside a weakref callback) still stops the work at the next raise_if_stopped, also
once an inner request has ended."""

from __future__ import annotations

import os
import signal
import weakref

import pytest

from swarm_supervisor.study.interrupt import Interrupted, StopRequest, raise_if_stopped


class Thing:
    pass


def signal_inside_a_weakref_callback(signum: int) -> None:
    """Deliver ``signum`` while a weakref callback runs: Python prints the handler's
    exception ("Exception ignored in ...") and goes on."""
    thing = Thing()
    ref = weakref.ref(thing, lambda _: os.kill(os.getpid(), signum))
    del thing  # the callback runs, the signal's handler raises inside it
    assert ref() is None


# The swallowed exception is what this test makes happen.
@pytest.mark.filterwarnings('ignore::pytest.PytestUnraisableExceptionWarning')
@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM])
def test_a_swallowed_signal_stops_at_the_next_check(signum):
    with StopRequest() as outer:
        with StopRequest() as inner:
            signal_inside_a_weakref_callback(signum)  # swallowed: the code goes on
            assert inner.requested == signum
        assert outer.requested == signum  # handed over as the inner request ended
        with pytest.raises(Interrupted) as stopped:
            raise_if_stopped()
    assert stopped.value.signum == signum
    raise_if_stopped()  # no request in force: nothing to raise


def test_without_a_signal_nothing_is_raised():
    with StopRequest() as request:
        raise_if_stopped()
    assert request.requested is None
