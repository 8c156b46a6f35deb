"""Sequence and boot-nonce bookkeeping: loss, duplicates, reordering and reboots."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from mona_controller.link.sequence import (
    DUPLICATE,
    FIRST,
    GAP,
    NEXT,
    REBOOT,
    REORDERED,
    STALE,
    Counter16,
    Stream,
    Tracker,
)


def feed(stream: Stream, seqs, nonce: int = 9) -> list[str]:
    return [stream.observe(seq, nonce) for seq in seqs]


def test_an_unbroken_sequence_loses_nothing_across_the_wrap():
    stream = Stream()
    assert feed(stream, [65534, 65535, 0, 1]) == [FIRST, NEXT, NEXT, NEXT]
    assert (stream.received, stream.lost, stream.duplicated) == (4, 0, 0)


def test_gaps_count_the_frames_lost():
    stream = Stream()
    assert feed(stream, [10, 11, 15, 65535 + 20]) == [FIRST, NEXT, GAP, GAP]
    assert stream.lost == 3 + (65555 % 65536 - 15 - 1)


def test_duplicates_are_counted_and_not_fresh():
    stream = Stream()
    assert feed(stream, [1, 2, 2, 3, 1]) == [FIRST, NEXT, DUPLICATE, NEXT, DUPLICATE]
    assert (stream.received, stream.duplicated, stream.lost) == (3, 2, 0)


def test_a_late_frame_is_reordered_not_lost():
    stream = Stream()
    assert feed(stream, [1, 3, 2, 4]) == [FIRST, GAP, REORDERED, NEXT]
    assert (stream.lost, stream.reordered, stream.received) == (0, 1, 4)


def test_a_new_boot_nonce_is_a_reboot_and_late_frames_of_the_old_boot_are_stale():
    stream = Stream()
    feed(stream, [100, 101], nonce=1)
    assert stream.observe(0, 2) == REBOOT
    assert stream.observe(102, 1) == STALE
    assert stream.observe(1, 2) == NEXT
    assert (stream.reboots, stream.stale, stream.lost) == (1, 1, 0)


@given(seqs=st.lists(st.integers(0, 500), min_size=1, max_size=200))
def test_every_frame_is_accounted_for(seqs):
    # Within a window smaller than half the range: fresh + duplicated = all, and the lost
    # are exactly the numbers missing between the oldest and the newest
    stream = Stream()
    verdicts = feed(stream, seqs)
    assert stream.received + stream.duplicated == len(seqs)
    assert verdicts.count(DUPLICATE) == len(seqs) - len(set(seqs))
    assert stream.lost == max(seqs) - min(seqs) + 1 - len(set(seqs))


def test_the_tracker_keeps_one_stream_per_robot():
    tracker = Tracker()
    assert tracker.observe(1, 5, 0) == FIRST
    assert tracker.observe(2, 5, 0) == FIRST
    assert tracker.observe(1, 5, 0) == DUPLICATE


def test_the_counter_wraps():
    counter = Counter16(65535)
    assert [counter.next() for _ in range(3)] == [65535, 0, 1]
