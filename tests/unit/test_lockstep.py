"""The world's rounds with its controllers (swarm_world.lockstep), without ROS: each rule of
docs/interfaces.md, "Stepping"."""

from __future__ import annotations

from swarm_world.lockstep import Answer, Lockstep, Outcome

STEP = 10
START = 1_000


def stamp(step: int) -> int:
    return START + step * STEP


def lockstep(population: int = 3, absent_after: int = 2) -> Lockstep:
    return Lockstep(population, START, absent_after, STEP)


def miss_rounds(rounds: Lockstep, robot: int, steps: range) -> None:
    """Every robot but ``robot`` answers these steps; ``robot`` misses them."""
    for step in steps:
        rounds.start_round(stamp(step))
        for other in range(rounds.population):
            if other != robot:
                rounds.answer(other, stamp(step), 0.1, 0.0)
        rounds.deadline()


def test_a_round_completes_on_the_last_awaited_answer_with_each_command():
    rounds = lockstep()
    rounds.start_round(stamp(0))
    assert rounds.answer(2, stamp(0), 0.3, -1.0) == Answer(Outcome.ACCEPTED)
    assert rounds.answer(0, stamp(0), 0.1, 1.0) == Answer(Outcome.ACCEPTED)
    assert rounds.waiting().tolist() == [1]
    assert rounds.answer(1, stamp(0), 0.2, 0.0) == Answer(Outcome.ACCEPTED, complete=True)
    assert not rounds.open
    linear, angular, cleaner = rounds.commands()
    assert linear.tolist() == [0.1, 0.2, 0.3] and angular.tolist() == [1.0, 0.0, -1.0]
    assert rounds.counters() == {'misses': [0, 0, 0], 'absent': [], 'dropped': 0,
                                 'duplicates': 0}


def test_a_command_for_another_step_is_dropped_and_counted():
    rounds = lockstep(population=1)
    rounds.start_round(stamp(3))
    assert rounds.answer(0, stamp(2), 0.5, 0.0).outcome is Outcome.DROPPED
    assert rounds.answer(0, stamp(4), 0.5, 0.0).outcome is Outcome.DROPPED
    assert rounds.dropped == 2 and rounds.open
    assert rounds.commands()[0].tolist() == [0.0]  # not applied


def test_a_duplicate_is_counted_and_the_first_answer_counts():
    rounds = lockstep(population=2)
    rounds.start_round(stamp(0))
    rounds.answer(0, stamp(0), 0.1, 0.0)
    assert rounds.answer(0, stamp(0), 0.9, 0.0) == Answer(Outcome.DUPLICATE)
    assert rounds.duplicates == 1 and rounds.open  # robot 1 is still awaited
    assert rounds.commands()[0].tolist() == [0.1, 0.0]


def test_a_repeat_arriving_after_its_round_is_a_duplicate_not_a_drop():
    # Step 0's readings are repeated until a robot answers; its answer to a repeat can
    # arrive after the round closed (found by the system test on a quiet machine).
    rounds = lockstep(population=1)
    rounds.start_round(stamp(0))
    assert rounds.answer(0, stamp(0), 0.1, 0.0).complete
    rounds.start_round(stamp(1))
    assert rounds.answer(0, stamp(0), 0.1, 0.0) == Answer(Outcome.DUPLICATE)
    assert rounds.answer(0, stamp(1), 0.2, 0.0).outcome is Outcome.ACCEPTED
    # An older stamp than the robot's last answer is a drop, as is a late first answer.
    assert rounds.answer(0, stamp(0), 0.1, 0.0).outcome is Outcome.DROPPED
    assert (rounds.duplicates, rounds.dropped) == (1, 1)
    assert rounds.commands()[0].tolist() == [0.2]


def test_at_the_deadline_the_late_robots_miss_and_hold_still():
    rounds = lockstep()
    rounds.start_round(stamp(0))
    rounds.answer(1, stamp(0), 0.2, 0.5)
    late, gone = rounds.deadline()
    assert late.tolist() == [0, 2] and gone.tolist() == []
    assert rounds.misses.tolist() == [1, 0, 1]
    linear, angular, _ = rounds.commands()
    assert linear.tolist() == [0.0, 0.2, 0.0] and angular.tolist() == [0.0, 0.5, 0.0]
    # Its round is over: a late answer is dropped, not applied.
    assert rounds.answer(0, stamp(0), 0.3, 0.0).outcome is Outcome.DROPPED
    assert rounds.commands()[0].tolist() == [0.0, 0.2, 0.0]


def test_a_new_round_forgets_the_last_commands():
    rounds = lockstep(population=1)
    rounds.start_round(stamp(0))
    rounds.answer(0, stamp(0), 0.2, 0.5)
    rounds.start_round(stamp(1))
    assert rounds.commands()[0].tolist() == [0.0] and rounds.waiting().tolist() == [0]


def test_misses_in_a_row_make_a_robot_absent_and_an_answer_resets_the_count():
    rounds = lockstep(absent_after=2)
    miss_rounds(rounds, 0, range(0, 1))
    rounds.start_round(stamp(1))
    rounds.answer(0, stamp(1), 0.1, 0.0)  # an answer between the misses: not in a row
    miss_rounds(rounds, 0, range(2, 3))
    assert rounds.counters()['absent'] == [] and rounds.misses[0] == 2
    rounds.start_round(stamp(3))
    late, gone = rounds.deadline()
    assert late.tolist() == [0, 1, 2] and gone.tolist() == [0]
    assert rounds.counters()['absent'] == [0] and rounds.misses.tolist() == [3, 1, 1]


def test_an_absent_robot_is_not_waited_for_not_counted_and_does_not_clean():
    rounds = lockstep(absent_after=1)
    rounds.set_cleaner(0, True)
    rounds.set_cleaner(1, True)
    miss_rounds(rounds, 0, range(0, 1))
    rounds.start_round(stamp(1))
    assert rounds.waiting().tolist() == [1, 2]
    rounds.answer(1, stamp(1), 0.1, 0.0)
    assert rounds.answer(2, stamp(1), 0.1, 0.0).complete  # without robot 0
    assert rounds.commands()[2].tolist() == [False, True, False]
    rounds.start_round(stamp(2))
    rounds.deadline()
    assert rounds.misses.tolist() == [1, 1, 1]  # absent: no more misses


def test_an_absent_robot_rejoins_on_an_older_stamp_of_the_episode_from_the_next_round():
    rounds = lockstep(absent_after=1)
    miss_rounds(rounds, 0, range(0, 3))
    rounds.start_round(stamp(3))
    assert rounds.answer(0, START - 1, 0.1, 0.0) == Answer(Outcome.DROPPED)  # before start_ns
    assert rounds.answer(0, stamp(4), 0.1, 0.0) == Answer(Outcome.DROPPED)  # not yet sent
    assert rounds.absent[0]
    assert rounds.answer(0, stamp(1), 0.1, 0.0) == Answer(Outcome.DROPPED, rejoined=True)
    assert rounds.counters()['absent'] == [] and rounds.waiting().tolist() == [1, 2]
    rounds.answer(1, stamp(3), 0.1, 0.0)
    assert rounds.answer(2, stamp(3), 0.1, 0.0).complete  # not waited for in this round
    assert rounds.misses[0] == 1
    rounds.start_round(stamp(4))
    assert rounds.waiting().tolist() == [0, 1, 2]


def test_an_absent_robot_answering_the_current_stamp_is_applied_at_once():
    rounds = lockstep(absent_after=1)
    miss_rounds(rounds, 0, range(0, 1))
    rounds.start_round(stamp(1))
    assert rounds.answer(0, stamp(1), 0.4, 0.0) == Answer(Outcome.ACCEPTED, rejoined=True)
    rounds.answer(1, stamp(1), 0.1, 0.0)
    assert rounds.answer(2, stamp(1), 0.1, 0.0).complete
    assert rounds.commands()[0].tolist() == [0.4, 0.1, 0.1]


def test_a_round_that_awaits_nobody_waits_for_its_deadline_or_a_rejoining_robot():
    rounds = lockstep(population=2, absent_after=1)
    rounds.start_round(stamp(0))
    rounds.deadline()
    rounds.start_round(stamp(1))
    assert rounds.open and rounds.waiting().tolist() == []
    assert rounds.answer(1, stamp(1), 0.1, 0.0) == Answer(Outcome.ACCEPTED, rejoined=True,
                                                          complete=True)


def test_a_non_finite_command_is_a_stop_and_a_stranger_is_ignored():
    rounds = lockstep(population=2)
    rounds.start_round(stamp(0))
    rounds.answer(0, stamp(0), float('nan'), 1.0)
    rounds.answer(1, stamp(0), 0.1, float('inf'))
    linear, angular, _ = rounds.commands()
    assert linear.tolist() == [0.0, 0.0] and angular.tolist() == [0.0, 0.0]
    assert rounds.answer(2, stamp(0), 0.1, 0.0) == Answer(Outcome.IGNORED)
    rounds.set_cleaner(5, True)  # no error, no effect
    assert rounds.counters()['dropped'] == 0


def test_realtime_takes_the_newest_command_and_stale_ones_hold_still():
    rounds = lockstep(population=3, absent_after=2)
    rounds.keep_latest(0, stamp(5), 0.5, 0.0)
    rounds.keep_latest(0, stamp(4), 0.4, 0.0)  # older than the one kept: ignored
    rounds.keep_latest(1, stamp(3), 0.3, float('nan'))  # broken: a stop, but fresh
    rounds.keep_latest(2, stamp(2), 0.2, 0.0)
    rounds.set_cleaner(2, True)
    rounds.realtime_step(stamp(5))
    linear, angular, cleaner = rounds.commands()
    # Robot 2 answers readings 3 steps old (> absent_after): absent, still, not cleaning.
    assert linear.tolist() == [0.5, 0.0, 0.0] and not cleaner.any()
    assert rounds.counters()['absent'] == [2]
    assert rounds.misses.tolist() == [0, 1, 1]  # no command for the readings of step 5
    rounds.keep_latest(2, stamp(5), 0.2, 0.0)
    rounds.realtime_step(stamp(6))  # robot 2 is back; robot 1's command is stale now
    assert rounds.counters()['absent'] == [1] and rounds.commands()[0].tolist() == [0.5, 0, 0.2]
    assert rounds.misses.tolist() == [1, 2, 2]
