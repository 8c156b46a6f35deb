"""StopRequest (swarm_supervisor.study.interrupt): a signal whose exception Python swallowed
(raised inside a weakref callback) still stops the work at the next raise_if_stopped, also
once an inner request has ended, and at the latest as the outermost request ends."""

from __future__ import annotations

import os
import signal
import weakref

import pytest

from swarm_supervisor.study.interrupt import (
    Interrupted,
    StopRequest,
    exit_status,
    raise_if_stopped,
)


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
    with pytest.raises(Interrupted) as at_the_end:
        with StopRequest() as outer:
            with StopRequest() as inner:
                signal_inside_a_weakref_callback(signum)  # swallowed: the code goes on
                assert inner.requested == signum
            assert outer.requested == signum  # handed over as the inner request ended
            with pytest.raises(Interrupted) as stopped:
                raise_if_stopped()
    assert stopped.value.signum == signum
    # The stop was asked for and the block went on (caught here): it still ends stopped.
    assert at_the_end.value.signum == signum
    raise_if_stopped()  # no request in force: nothing to raise


def test_without_a_signal_nothing_is_raised():
    with StopRequest() as request:
        raise_if_stopped()
    assert request.requested is None


@pytest.mark.filterwarnings('ignore::pytest.PytestUnraisableExceptionWarning')
def test_the_outermost_request_raises_a_lost_signal_as_it_ends():
    with pytest.raises(Interrupted) as stopped:
        with StopRequest():
            with StopRequest():
                signal_inside_a_weakref_callback(signal.SIGTERM)  # no check after it
    assert stopped.value.status == 143


@pytest.mark.filterwarnings('ignore::pytest.PytestUnraisableExceptionWarning')
def test_a_lost_signal_carries_what_finished():
    with pytest.raises(Interrupted) as stopped:
        with StopRequest():
            signal_inside_a_weakref_callback(signal.SIGINT)
            raise_if_stopped({'episodes/a': (1.0, 0.5)})
    assert stopped.value.ran == {'episodes/a': (1.0, 0.5)}
    assert exit_status(stopped.value) == 130 and exit_status(KeyboardInterrupt()) == 130
