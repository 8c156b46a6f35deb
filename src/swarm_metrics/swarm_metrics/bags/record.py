"""What a recorder keeps of an episode (:mod:`swarm_metrics.bags.recording`): the record it is
writing (:class:`EpisodeRecord`: its bag, its metrics replica, what has arrived and whether
everything the world counted has), the record it closed (:class:`Closed`, with the
completeness verdict on its bag) and what an announcement did (:class:`Announced`).

``/world/robot_states`` has no stamp: the world publishes one with every ``/world/poses``,
just before it, so the n-th states message of an episode belongs to its n-th poses message;
the record pairs them by that count (whichever topic's message comes first), and the
recorder records the states of each sampled pose (and of t = 0) at the pose's time.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import NamedTuple

from mona_controller.contract import WorldStatus
from mona_controller.topics import CUE_MAP, ROBOT_STATES, SOURCES
from swarm_metrics.bags.analysis import EpisodeSetup, MetricsReplica
from swarm_metrics.bags.checks import Finding
from swarm_metrics.bags.writer import EpisodeBagWriter

#: A metric row as the node publishes it: (log time ns, {metric: value}).
Row = tuple[int, dict[str, float]]
#: What a record must hold at the episode's ``start_ns`` (beside the announcement and the
#: t = 0 sample it gives): the completeness checks demand the states and the sources there,
#: and the cue map of t = 0 makes the bag the embedded runner's. The world publishes these
#: on keep-last-1 (map, sources) or paired (states) topics before its first step, and holds
#: that step until the record has them.
START = frozenset({CUE_MAP, SOURCES, ROBOT_STATES})


@dataclasses.dataclass
class EpisodeRecord:
    """What is known of the episode being recorded."""

    setup: EpisodeSetup
    bag: EpisodeBagWriter
    replica: MetricsReplica
    metrics: tuple[str, ...]  #: the metrics recorded (the table's when the episode opened)
    samples: int = 0  #: metric samples taken (t = 0 included)
    cleaning: int = 0  #: /world/cleaning messages recorded
    last_pose_ns: int = 0
    last_map_ns: int = -1
    last_sources_ns: int = -1  #: the latest /world/sources seen (-1: none yet)
    #: The topics of :data:`START` recorded at ``start_ns`` so far.
    started: set[str] = dataclasses.field(default_factory=set)
    poses_seen: int = 0  #: /world/poses messages of the episode, t = 0's included
    states_seen: int = 0  #: /world/robot_states messages of the episode
    #: pose index -> log time, of sampled poses whose states have not arrived yet
    states_wanted: dict[int, int] = dataclasses.field(default_factory=dict)
    #: pose index -> states that arrived before their pose
    states_early: dict[int, bytes] = dataclasses.field(default_factory=dict)
    running: bool = False  #: the world said it runs the episode
    obstacles: bool = False  #: the world's /world/obstacles is in the bag
    final: WorldStatus | None = None  #: the world's finished or failed status
    cleaning_stamps: list[int] = dataclasses.field(default_factory=list)  #: sorted
    counted: tuple[int, int] | None = None  #: the world's latest (time_ns, cleaning_events)

    @property
    def recorded_ns(self) -> int:
        """Sim time up to which the record is whole: the last sample's time, once the start
        (:data:`START` at ``start_ns``) is recorded; ``start_ns - 1`` before."""
        if not self.started >= START:
            return self.setup.start_ns - 1
        return self.setup.start_ns + max(self.samples - 1, 0) * self.setup.sample_ns

    def all_arrived(self) -> bool:
        """The world reported the end and everything its final status counts is here."""
        if self.final is None:
            return False
        # The world publishes the final poses and cue map, then its final status, on three
        # topics: any of them may come last.
        # A world that publishes states and sources publishes them with the poses and the map.
        end_ns, counted = self.final.time_ns, self.final.cleaning_events
        return (self.last_pose_ns >= end_ns and self.last_map_ns >= end_ns
                and (counted is None or self.cleaning >= counted)
                and (self.states_seen == 0 or self.states_seen >= self.poses_seen)
                and (self.last_sources_ns < 0 or self.last_sources_ns >= end_ns))

    # --- the robots' states: paired with the poses by count --------------------------------

    def pose_sampled(self, stamp: int) -> bytes | None:
        """The next pose is a sample at ``stamp``: the states to record there now, if they
        came before it (else they are wanted there, :meth:`states_arrived`)."""
        index, self.poses_seen = self.poses_seen, self.poses_seen + 1
        data = self.states_early.pop(index, None)
        if data is None:
            self.states_wanted[index] = stamp
        return data

    def pose_skipped(self) -> None:
        """The next pose is not a sample: its states are not recorded."""
        self.states_early.pop(self.poses_seen, None)
        self.poses_seen += 1

    def states_arrived(self, data: bytes) -> int | None:
        """A /world/robot_states message: the time to record it at (its pose is a sample that
        came first), or None (its pose is on its way: kept for it; or not a sample)."""
        index, self.states_seen = self.states_seen, self.states_seen + 1
        stamp = self.states_wanted.pop(index, None)
        if stamp is None and index >= self.poses_seen:
            self.states_early[index] = bytes(data)  # its pose is on its way
        return stamp


@dataclasses.dataclass(frozen=True)
class Closed:
    """An episode's record, closed, with the completeness verdict on its bag."""

    episode: int
    start_ns: int
    path: Path
    messages: int
    #: What :func:`~swarm_metrics.completeness.check_bag` found (empty: the record is
    #: complete; None: closed without a verdict, see :meth:`Recorder.close`).
    findings: tuple[Finding, ...] | None

    @property
    def complete(self) -> bool:
        """The bag passed every completeness check."""
        return self.findings == ()

    @property
    def problems(self) -> tuple[str, ...]:
        """What the record lacks, one line each (empty: it is complete)."""
        if self.findings is None:
            return ('not judged: closed before the episode ended; `mona-swarm analyze` '
                    'judges it',)
        return tuple(map(str, self.findings))


class Announced(NamedTuple):
    """What an /episode message did."""

    setup: EpisodeSetup | None  #: the episode it opened (None: a shutdown, or redelivered)
    closed: Closed | None  #: the previous episode's record, if this closed it
    rows: list[Row]  #: metric rows to publish (the new episode's t = 0)
    shutdown: bool = False  #: the supervisor announced the end of the run
