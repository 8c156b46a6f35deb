"""An episode as its bag recorded it, read for a video: poses, states, cleaning, cue maps,
metrics and obstacles, in ns from the episode's start (either runner's bag)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from mona_controller.topics import (
    CLEANING,
    CUE_MAP,
    EPISODE,
    METRICS_PREFIX,
    OBSTACLES,
    POSES,
    ROBOT_STATES,
    STATUS,
)
from swarm_metrics.bags.analysis import AnnouncementError, EpisodeSetup
from swarm_metrics.bags.reader import cue_of, decode, decode_json, find_mcap, poses_of
from swarm_metrics.bags.scan import McapScan
from swarm_world.arena import Obstacle
from swarm_world.messages.cdr import states_from_cdr
from swarm_world.messages.markers import obstacles_from_markers


class AnimateError(Exception):
    """The input cannot be animated (no bag, no announcement, nothing recorded)."""


@dataclasses.dataclass
class Record:
    """What a video needs from an episode's bag (times in ns from the episode's start)."""

    setup: EpisodeSetup
    runner: str  #: 'embedded' or the world's mode
    pose_times: np.ndarray  #: [S]
    poses: np.ndarray  #: [S, N, 3]
    states: np.ndarray | None  #: [S, N] controller states, if recorded (embedded bags)
    cleaning: list[tuple[int, np.ndarray]]  #: (time, poses of the cleaners)
    cue_maps: list[tuple[int, np.ndarray]]  #: the recorded cue maps (uint8, core order)
    metrics: dict[str, tuple[np.ndarray, np.ndarray]]  #: name -> (times, values)
    #: The shapes of the bag's /world/obstacles (none recorded: none)
    obstacles: tuple[Obstacle, ...] = ()

    @property
    def duration_ns(self) -> int:
        """The episode's recorded sim-time span."""
        return self.setup.end_ns - self.setup.start_ns


def find_bag(path: str | Path) -> Path:
    """The bag of an episode folder (``<dir>/bag``, else a recovered copy), or ``path`` itself.

    Raises:
        AnimateError: no bag there.
    """
    path = Path(path)
    if path.is_dir() and not list(path.glob('*.mcap')):
        for name in ('bag', 'bag_recovered'):
            if (path / name).is_dir():
                return path / name
        raise AnimateError(f'{path} holds no bag (no {path}/bag and no .mcap): record one with '
                           '`mona-swarm run --bag` or scripts/swarm.sh')
    if not path.exists():
        raise AnimateError(f'{path} does not exist')
    return path


def read_record(path: str | Path) -> Record:
    """Read what a video shows from an episode folder or bag.

    Raises:
        AnimateError: no bag, no usable announcement, or no poses recorded.
        BagError: the bag is damaged or cut short (``mona-swarm recover`` it first).
    """
    mcap = find_mcap(find_bag(path))
    setup = None
    runner = None
    times, poses, state_times, states, cleaning, maps = [], [], [], [], [], []
    metrics: dict[str, list[tuple[int, float]]] = {}
    obstacles = None
    for message in McapScan(mcap):
        topic = message.topic
        if topic == POSES:
            times.append(message.log_time)
            poses.append(poses_of(decode(message)))
        elif topic == ROBOT_STATES:
            state_times.append(message.log_time)
            states.append(states_from_cdr(message.data))
        elif topic == CLEANING:
            cleaning.append((message.log_time, poses_of(decode(message))))
        elif topic == CUE_MAP:
            maps.append((message.log_time, cue_of(decode(message))))
        elif topic.startswith(METRICS_PREFIX):
            metrics.setdefault(topic[len(METRICS_PREFIX):], []).append(
                (message.log_time, float(decode(message).data)))
        elif topic == OBSTACLES and obstacles is None:
            obstacles = obstacles_from_markers(decode(message).markers)
        elif topic == STATUS and runner is None:
            runner = decode_json(message).get('mode')  # one status tells
        elif topic == EPISODE and setup is None:
            document = decode_json(message)
            if not document.get('shutdown'):
                try:
                    setup = EpisodeSetup.from_announcement(document)
                except AnnouncementError as error:
                    raise AnimateError(f'{mcap}: {error}') from None
    if setup is None:
        raise AnimateError(f'{mcap} holds no /episode announcement: nothing to animate')
    start = setup.start_ns
    # The t = 0 poses are the announced ones (the world's first poses are not recorded).
    pose_times = np.array([0, *(t - start for t in times)], dtype=np.int64)
    all_poses = np.stack([setup.initial_poses, *poses])
    state_array = None
    if states:
        by_time = dict(zip(state_times, states))
        initial = by_time.get(start, np.zeros(setup.population, dtype=np.uint8))
        state_array = np.stack([initial] + [by_time.get(t, initial) for t in times])
    order = np.argsort(pose_times, kind='stable')
    return Record(
        setup=setup, runner=runner or 'unknown runner', pose_times=pose_times[order],
        poses=all_poses[order],
        states=None if state_array is None else state_array[order],
        cleaning=sorted(((t - start, p) for t, p in cleaning), key=lambda e: e[0]),
        cue_maps=[(t - start, m) for t, m in sorted(maps, key=lambda e: e[0])],
        metrics={name: (np.array([t - start for t, _ in rows], dtype=np.int64),
                        np.array([v for _, v in rows])) for name, rows in metrics.items()},
        obstacles=obstacles or ())

