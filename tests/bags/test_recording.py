"""The metrics node's recording logic without ROS: a Recorder fed an episode's messages as
the CDR bytes the world sends (taken from a bag of an embedded episode) writes a bag equal to
the embedded run, files messages that come before their announcement, and says exactly what
an incomplete record lacks."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mona_controller.topics import CLEANING, EPISODE, POSES, ROBOT_STATES, STATUS
from swarm_metrics.bags.analysis import recompute
from swarm_metrics.bags.checks import failed_checks
from swarm_metrics.bags.completeness import check_bag
from swarm_metrics.bags.reader import find_mcap, read_episode_bag
from swarm_metrics.bags.recording import Recorder
from swarm_metrics.bags.scan import McapScan
from swarm_supervisor.config import load_config
from swarm_world.messages.cdr import pose_array_cdr, states_from_cdr

from bagtools import embedded_episode_bag, string_cdr

CONFIG = load_config().replace(episode={'population': 10, 'duration': 12.0, 'seed': 3})


@pytest.fixture(scope='module')
def world_messages(tmp_path_factory) -> tuple[list[tuple[str, bytes]], list[dict]]:
    """(the messages of a 12 s episode as (topic, CDR) in the world's order, its rows)."""
    path = tmp_path_factory.mktemp('source') / 'bag'
    rows = embedded_episode_bag(path, CONFIG, map_period=4.0)
    return world_stream(path), rows


def world_stream(path: Path) -> list[tuple[str, bytes]]:
    """What the world and the supervisor sent for the episode of the bag at ``path``."""
    messages = [(m.topic, m.data) for m in McapScan(find_mcap(path))
                if not m.topic.startswith('/metrics/')]
    # The bag keeps the states of t = 0 but not its pose (t = 0's sample is the
    # announcement's): the world sent both, the states first.
    announced = json.loads(next(data for topic, data in messages
                                if topic == EPISODE)[8:].rstrip(b'\x00'))
    first_states = next(i for i, m in enumerate(messages) if m[0] == ROBOT_STATES)
    messages.insert(first_states + 1, (POSES, pose_array_cdr(np.array(announced['poses']),
                                                             announced['start_ns'])))
    return messages


def feed(recorder: Recorder, messages: list[tuple[str, bytes]]) -> None:
    for topic, data in messages:
        if topic == EPISODE:
            recorder.announce(data)
        elif topic == STATUS:
            recorder.status(data)
        else:
            recorder.route(topic, data)


def make_recorder(out: Path) -> Recorder:
    return Recorder(out, chunk_period=5.0, cue_map_period=0.0, clock_period=0.1)


def test_a_whole_episode_is_recorded_complete_and_equal_to_the_embedded_run(
        world_messages, tmp_path):
    messages, rows = world_messages
    recorder = make_recorder(tmp_path)
    feed(recorder, messages)
    assert recorder.done()  # the final status, poses and map are in: nothing more to wait for
    closed, _ = recorder.close()
    assert closed.problems == ()
    assert recompute(read_episode_bag(closed.path)).rows == rows


def test_messages_before_their_announcement_are_filed(world_messages, tmp_path):
    messages, rows = world_messages
    first_poses = next(i for i, (topic, _) in enumerate(messages) if topic == POSES)
    announcement = next(i for i, (topic, _) in enumerate(messages) if topic == EPISODE)
    early = messages[announcement + 1:first_poses + 3]  # cleaning and poses of t = 0 .. 2 s
    assert {topic for topic, _ in early} >= {POSES}
    rest = [m for i, m in enumerate(messages) if not announcement < i < first_poses + 3]
    recorder = make_recorder(tmp_path)
    feed(recorder, early)
    assert recorder.episode is None  # nothing to file them in yet
    feed(recorder, rest)
    closed, _ = recorder.close()
    assert closed.problems == ()
    assert recompute(read_episode_bag(closed.path)).rows == rows


@pytest.mark.parametrize('lose, fails', [
    # a cleaning event the world counted never arrived
    (CLEANING, {'cleaning', 'cue_maps'}),
    (POSES, {'samples'}),  # the first sampled pose after t = 0: the t = 1 s sample is missing
    (STATUS, {'finished'}),  # the last status, the finished one
])
def test_an_incomplete_record_says_what_it_lacks(world_messages, tmp_path, lose, fails):
    messages, _ = world_messages
    kinds = [topic for topic, _ in messages]
    if lose == STATUS:  # the last status is the finished one
        index = max(i for i, topic in enumerate(kinds) if topic == STATUS)
    else:  # the first of its kind after t = 0's pose
        index = next(i for i, topic in enumerate(kinds) if topic == lose
                     and i > kinds.index(POSES))
    recorder = make_recorder(tmp_path)
    feed(recorder, messages[:index] + messages[index + 1:])
    # What the final status counts is missing: the recorder waits (the node, finish_timeout).
    assert recorder.done() == (lose == POSES)
    closed, _ = recorder.close()
    # The verdict is the one analyze gives on the same bag.
    assert set(failed_checks(closed.findings)) == fails, closed.problems
    assert list(closed.findings) == check_bag(read_episode_bag(closed.path))[1]


def test_an_episode_that_ends_between_sample_times_is_complete(tmp_path):
    """5 s is 156.25 steps of 32 ms: the world steps to 5.024 s, past the announced end."""
    config = CONFIG.replace(episode={'duration': 5.0})
    rows = embedded_episode_bag(tmp_path / 'source', config, map_period=4.0)
    recorder = make_recorder(tmp_path / 'out')
    feed(recorder, world_stream(tmp_path / 'source'))
    assert recorder.done()
    closed, _ = recorder.close()
    assert closed.problems == ()
    assert [row['t'] for row in rows] == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    assert recompute(read_episode_bag(closed.path)).rows == rows


def test_samples_wait_for_the_cleaning_events_the_world_counted(world_messages, tmp_path):
    """After a stall the two topics' repairs come in any order: here every cleaning event
    arrives after all the poses. The world's status counts them, so no sample is taken
    before its cleaning is in, and the online metrics still equal the embedded run."""
    messages, rows = world_messages
    cleaning = [m for m in messages if m[0] == CLEANING]
    others = [m for m in messages if m[0] != CLEANING]
    end = max(i for i, (topic, _) in enumerate(others) if topic == STATUS)  # finished
    recorder = make_recorder(tmp_path)
    published = []
    for topic, data in others[:end] + cleaning + others[end:]:
        if topic == EPISODE:
            published += recorder.announce(data).rows
        elif topic == STATUS:
            published += recorder.status(data)[1]
        else:
            published += recorder.route(topic, data)
    assert len(cleaning) >= 3
    closed, last = recorder.close()
    assert closed.problems == ()
    assert [row for _, row in published + last] == rows


def test_a_status_that_comes_before_its_announcement_counts(world_messages, tmp_path):
    """The world's status and the announcement travel on two topics: a status of the episode
    may arrive first. It is kept: here it is the only one before the end and comes from a
    world that does not count cleaning events (a driver), so samples must flow at once
    instead of waiting for a count that never comes."""
    messages, rows = world_messages
    driver_status = (STATUS, string_cdr(json.dumps({'episode': 0, 'state': 'running',
                                                    'time_ns': 7 * 10**9})))
    statuses = [i for i, (topic, _) in enumerate(messages) if topic == STATUS]
    kept = [m for i, m in enumerate(messages) if i not in statuses[:-1]]  # the finished one
    recorder = make_recorder(tmp_path)
    recorder.status(driver_status[1])
    published = []
    for topic, data in kept[:-1]:  # all but the finished status
        if topic == EPISODE:
            published += recorder.announce(data).rows
        else:
            published += recorder.route(topic, data)
    assert len(published) >= len(rows) - 1  # every sample but the last was taken on the way


@pytest.mark.parametrize('first', [POSES, ROBOT_STATES])
def test_robot_states_are_paired_with_their_poses_whichever_comes_first(world_messages,
                                                                         tmp_path, first):
    """/world/robot_states has no stamp: the recorder pairs the n-th with the n-th poses and
    records it at that pose's time, whichever of the two topics' messages arrives first."""
    messages, _ = world_messages
    kinds = [topic for topic, _ in messages]
    pairs = [i for i in range(len(kinds) - 1) if kinds[i:i + 2] == [POSES, ROBOT_STATES]]
    # The bag has poses, then states; t = 0's pair is as the world sent it, states first.
    assert len(pairs) == kinds.count(ROBOT_STATES) - 1 > 10
    if first == ROBOT_STATES:  # each states message before its poses, as the world sends
        messages = list(messages)
        for i in pairs:
            messages[i], messages[i + 1] = messages[i + 1], messages[i]
    recorder = make_recorder(tmp_path)
    feed(recorder, messages)
    assert recorder.done()
    closed, _ = recorder.close()
    assert closed.problems == ()
    bag = read_episode_bag(closed.path)
    sent = [states_from_cdr(data).tobytes() for topic, data in messages
            if topic == ROBOT_STATES]
    assert [row.tobytes() for _, row in bag.states] == sent
    start = bag.announcement['start_ns']  # t = 0's pose is the announcement's, not recorded
    assert [t for t, _ in bag.states] == [start] + [t for t, _ in bag.poses]  # the poses' times
    assert len({row.tobytes() for _, row in bag.states}) > 1  # not one state repeated


def test_a_record_without_robot_states_says_so(world_messages, tmp_path):
    messages, _ = world_messages
    recorder = make_recorder(tmp_path)
    feed(recorder, [m for m in messages if m[0] != ROBOT_STATES])
    closed, _ = recorder.close()
    assert failed_checks(closed.findings) == ['robot_states'], closed.problems
    assert recorder.episode is None and not closed.complete
