"""The contract as plain Python: recorder reports round-trip, and the book the world and the
supervisor keep says who records, who lags and who closed."""

from __future__ import annotations

import pytest

from mona_controller import contract, topics
from mona_controller.contract import (
    ContractError,
    RecorderBook,
    RecorderReport,
    RecorderState,
    recorder_names,
)

RECORDING, CLOSED = RecorderState.RECORDING, RecorderState.CLOSED


def test_report_round_trips_through_json():
    report = RecorderReport('metrics', 3, 7_000, CLOSED, 9_000, False, ('2 of 61 samples',),
                            '/out/episode_3/bag')
    assert RecorderReport.from_json(report.to_json()) == report


@pytest.mark.parametrize('text, named', [
    ('{"episode": 0, "start_ns": 0, "state": "recording"}', "'recorder'"),
    ('{"recorder": "m", "episode": 0, "start_ns": 0, "state": "asleep"}', 'asleep'),
    ('{"recorder": "m", "episode": "x", "start_ns": 0, "state": "closed"}', 'x'),
    ('not json', 'not json'),
])
def test_malformed_reports_are_named(text, named):
    with pytest.raises(ContractError, match=named):
        RecorderReport.from_json(text)


def test_recorder_names_of_a_parameter():
    assert recorder_names('') == ()
    assert recorder_names(' metrics, video ,') == ('metrics', 'video')


def test_book_follows_each_recorder_per_episode():
    book = RecorderBook(['metrics', 'video'])
    assert book.not_recording(0, 100) == ['metrics', 'video']
    assert not book.update(RecorderReport('stranger', 0, 100, RECORDING))
    book.update(RecorderReport('metrics', 0, 100, RECORDING, 100))
    assert book.not_recording(0, 100) == ['video']
    # The same episode number of another run (another start) does not count.
    book.update(RecorderReport('video', 0, 999, RECORDING, 999))
    assert book.not_recording(0, 100) == ['video']
    book.update(RecorderReport('video', 0, 100, RECORDING, 5_000))
    assert book.not_recording(0, 100) == []
    assert book.behind(0, 100, 1_000) == ['metrics']
    book.update(RecorderReport('metrics', 0, 100, RECORDING, 1_000))
    assert book.behind(0, 100, 1_000) == []
    book.update(RecorderReport('metrics', 0, 100, CLOSED, 1_000, True))
    assert book.behind(0, 100, 10**12) == ['video']  # a closed record holds nobody back
    assert list(book.closed(0, 100)) == ['metrics']
    assert book.closed(1, 100) == {}


def test_topic_names_are_absolute_or_per_robot():
    assert topics.robot_topic(12, topics.CMD_VEL) == '/mona_12/cmd_vel'
    assert contract.base_frame(0) == 'mona_0/base_link'
    assert all(name.startswith('/') for name in (topics.POSES, topics.RECORDERS,
                                                 topics.EPISODE, topics.STATUS))


def test_the_topic_names_the_contract_reexported_forward_for_one_release():
    with pytest.warns(DeprecationWarning, match='mona_controller.contract.POSES moved to '
                                                'mona_controller.topics.POSES'):
        assert contract.POSES == topics.POSES
    with pytest.raises(AttributeError):
        contract.NO_SUCH_TOPIC  # noqa: B018


def test_announcement_round_trips_and_says_what_is_wrong():
    from mona_controller.contract import Announcement
    announced = Announcement(2, seed=9, population=2, duration=60.0, start_ns=10**9,
                             poses=((0.5, 0.5, 0.0), (1.0, 1.5, 3.0)),
                             parameters={'world': {}})
    assert Announcement.from_json(announced.to_json()) == announced
    assert announced.key == (2, 9, 10**9)
    shutdown = Announcement.from_json(Announcement(2, shutdown=True).to_json())
    assert shutdown.shutdown and shutdown.episode == 2
    with pytest.raises(ContractError, match="no 'seed'"):
        Announcement.from_json('{"episode": 0, "parameters": {}, "poses": []}')
    with pytest.raises(ContractError, match='population 3 but 2 poses'):
        Announcement.from_dict({**announced.__dict__, 'population': 3})
    with pytest.raises(ContractError, match='not all finite'):
        Announcement.from_dict({**announced.__dict__, 'poses': [[0, 0, 0], [1, 'nan', 0]]})
    with pytest.raises(ContractError, match='not JSON'):
        Announcement.from_json('{')


def test_world_status_round_trips_and_tolerates_what_a_driver_does_not_count():
    from mona_controller.contract import WorldState, WorldStatus
    status = WorldStatus(3, WorldState.FINISHED, step=10, steps=10, time_ns=320_000_000,
                         misses=(0, 2), absent=(1,), dropped=1, cleaning_events=4)
    assert WorldStatus.from_json(status.to_json()) == status
    assert status.ended and not WorldStatus(3, WorldState.RUNNING).ended
    driver = WorldStatus.from_json('{"episode": 0, "state": "running", "time_ns": 5}')
    assert driver.cleaning_events is None and driver.misses == ()
    with pytest.raises(ContractError, match="without 'state'"):
        WorldStatus.from_json('{"episode": 0}')
    with pytest.raises(ContractError, match='malformed'):
        WorldStatus.from_json('{"episode": 0, "state": "dancing"}')
    with pytest.raises(ContractError, match='not a JSON object'):
        WorldStatus.from_json('[1]')
