"""The controller node's reading rules without ROS: halves paired by stamp in either order,
each stamp answered once in time order, repeats answered from memory, bounded pending halves,
and bad input logged at most once per period for each kind."""

from __future__ import annotations

from mona_controller.pairing import ANSWER_HISTORY, PENDING_LIMIT, RateLimitedLog, ReadingPairs

START = 1_000


class Answerer:
    """Answers a pair with (stamp, ground, proximity) and records every call."""

    def __init__(self) -> None:
        self.calls: list[int] = []

    def __call__(self, stamp: int, ground: str, proximity: str) -> tuple[int, str, str]:
        self.calls.append(stamp)
        return stamp, ground, proximity


def started() -> tuple[ReadingPairs, Answerer]:
    answerer = Answerer()
    pairs = ReadingPairs(answerer)
    assert pairs.start(START) == []
    return pairs, answerer


def answer(pairs: ReadingPairs, stamp: int, ground: str = 'g', proximity: str = 'p') -> list:
    """Both halves of ``stamp``; what the second half answers."""
    assert pairs.add_ground(stamp, ground) == []
    return pairs.add_proximity(stamp, proximity)


def test_halves_pair_by_stamp_in_either_order():
    pairs, answerer = started()
    assert pairs.add_proximity(START + 2, 'p2') == []
    assert pairs.add_ground(START + 1, 'g1') == []
    assert pairs.add_ground(START + 2, 'g2') == [(START + 2, (START + 2, 'g2', 'p2'))]
    # The ground half of START + 1 can no longer be answered (time has moved on): dropped.
    assert pairs.add_proximity(START + 1, 'p1') == []
    assert answerer.calls == [START + 2]
    assert pairs.ground == {} and pairs.proximity == {}


def test_repeats_get_the_remembered_answer_not_a_new_one():
    pairs, answerer = started()
    for k in range(3):
        answer(pairs, START + k, ground=f'g{k}')
    # An older answered stamp repeated with other readings: its first answer again.
    assert answer(pairs, START, ground='other') == [(START, (START, 'g0', 'p'))]
    assert answer(pairs, START + 2, ground='other') == [(START + 2, (START + 2, 'g2', 'p'))]
    assert answerer.calls == [START, START + 1, START + 2]


def test_only_the_last_answers_are_remembered():
    pairs, answerer = started()
    for k in range(ANSWER_HISTORY + 1):
        answer(pairs, START + k)
    assert answer(pairs, START) == []  # forgotten: too old to answer
    assert answer(pairs, START + 1) == [(START + 1, (START + 1, 'g', 'p'))]
    assert len(answerer.calls) == ANSWER_HISTORY + 1


def test_readings_wait_for_the_episode_and_those_before_its_start_are_ignored():
    answerer = Answerer()
    pairs = ReadingPairs(answerer)
    assert answer(pairs, START - 1) == []
    assert answer(pairs, START + 1) == []
    assert answer(pairs, START) == []
    assert answerer.calls == []  # no episode yet: time is not known
    answers = pairs.start(START)
    assert [stamp for stamp, _ in answers] == [START, START + 1]  # in time order
    assert answer(pairs, START - 2) == []
    assert answerer.calls == [START, START + 1]


def test_a_new_episode_forgets_the_answers_of_the_last():
    pairs, answerer = started()
    answer(pairs, START + 5)
    pairs.start(START + 5)
    assert answer(pairs, START + 5, ground='new') == [(START + 5, (START + 5, 'new', 'p'))]
    assert answerer.calls == [START + 5, START + 5]


def test_unmatched_halves_are_bounded_per_topic_oldest_dropped_first():
    pairs, answerer = started()
    for k in range(PENDING_LIMIT + 3):
        pairs.add_ground(START + k, 'g')
    pairs.add_proximity(START + 100, 'p')
    assert sorted(pairs.ground) == [START + k for k in range(3, PENDING_LIMIT + 3)]
    assert list(pairs.proximity) == [START + 100]
    assert pairs.add_proximity(START + 2, 'p') == []  # its ground half was dropped
    assert pairs.add_proximity(START + 3, 'p') == [(START + 3, (START + 3, 'g', 'p'))]


def test_each_kind_of_message_is_logged_at_most_once_per_period():
    now = [0.0]
    lines: list[str] = []
    log = RateLimitedLog(lines.append, period=5.0, clock=lambda: now[0])
    assert log('ground', 'bad ground 1')
    now[0] = 1.0
    assert log('proximity', 'bad scan 1')  # another kind is not held back
    now[0] = 4.9
    assert not log('ground', 'bad ground 2')
    now[0] = 5.0
    assert log('ground', 'bad ground 3')
    assert not log('proximity', 'bad scan 2')
    assert lines == ['bad ground 1', 'bad scan 1', 'bad ground 3']
