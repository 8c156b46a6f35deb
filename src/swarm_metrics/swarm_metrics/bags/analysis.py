"""Recomputing an episode's metrics from its bag, and the replica the metrics node runs online.

The cue is rebuilt from the episode's parameters (:class:`swarm_world.field.CueField`, the
class the world itself runs: initial field, cleaning, transport ticks) by replaying the
``/world/cleaning`` events through it, and sampled like the embedded runner samples: a
row is taken at the first world state at or after each ``sample_period`` boundary, labelled
with the boundary. The metrics node drives the same :class:`MetricsReplica` with live messages,
so its online metrics and this offline recomputation agree by construction.
"""

from __future__ import annotations

import collections
import dataclasses
import math
from typing import Any

import numpy as np

from mona_controller.contract import Announcement, ContractError
from mona_controller.controllers import State
from mona_controller.keys import moved_keys, relocate
from mona_controller.mappings import from_mapping
from mona_controller.mona import MonaParams
from swarm_metrics.bags.reader import EpisodeBag
from swarm_metrics.bags.scan import BagError
from swarm_metrics.metrics import MetricsParams, metric_names, sample_field
from swarm_world.field import CueField
from swarm_world.params import WorldParams
from swarm_world.sensing.params import SensingParams
from swarm_world.timing import crossed, steps_for

#: Later than any sim time.
NEVER = 2**63 - 1


class AnnouncementError(ValueError):
    """An /episode announcement that lacks a field or carries a bad parameter."""


def _states(announced: Announcement) -> tuple[State, ...]:
    try:
        return announced.robot_states()
    except KeyError:
        return ()


@dataclasses.dataclass(frozen=True)
class EpisodeSetup:
    """What an episode announcement fixes: seed, start, initial poses and the parameters."""

    episode: int
    seed: int
    population: int
    duration: float  #: s
    start_ns: int  #: sim time of the episode's t = 0
    initial_poses: np.ndarray  #: [N, 3]
    world: WorldParams
    mona: MonaParams
    sensing: SensingParams
    metrics: MetricsParams
    #: every section, as announced (a key that moved since at its new key)
    parameters: dict[str, Any]
    #: the controller kind's states, by code: announced, or (an older announcement) the
    #: kind's if it is registered here, else none
    states: tuple[State, ...] = ()

    @classmethod
    def from_announcement(cls, announcement: dict[str, Any]) -> EpisodeSetup:
        """Parse and validate the supervisor's /episode message (docs/interfaces.md).

        Raises:
            AnnouncementError: naming the missing field or the bad parameter.
        """
        try:
            announced = Announcement.from_dict(announcement)
            if announced.shutdown:
                raise AnnouncementError('a shutdown announcement announces no episode')
            # An announcement recorded before keys moved holds them at their old places.
            parameters = relocate(announced.parameters, moved_keys(SensingParams, 'sensing.'),
                                  warn=False)
            setup = cls(
                episode=announced.episode, seed=announced.seed,
                population=announced.population, duration=announced.duration,
                start_ns=announced.start_ns,
                initial_poses=np.asarray(announced.poses, dtype=np.float64).reshape(-1, 3),
                world=from_mapping(WorldParams, parameters.get('world'), 'world.'),
                mona=from_mapping(MonaParams, parameters.get('mona'), 'mona.'),
                sensing=from_mapping(SensingParams, parameters.get('sensing'), 'sensing.'),
                metrics=from_mapping(MetricsParams, parameters.get('metrics'), 'metrics.'),
                parameters=parameters, states=_states(announced))
        except ContractError as error:
            raise AnnouncementError(str(error)) from None
        except (TypeError, ValueError) as error:  # ParameterError included
            raise AnnouncementError(f'bad episode announcement: {error}') from None
        return setup

    @property
    def sample_ns(self) -> int:
        """The metrics sample period in ns."""
        return round(self.metrics.sample_period * 1e9)

    @property
    def end_ns(self) -> int:
        """Sim time at which the episode ends: after its last whole step (the duration rounded
        up to whole steps, as the world steps it)."""
        step_ns = self.world.step_ns
        return self.start_ns + steps_for(self.duration, step_ns) * step_ns


class MetricsReplica:
    """The cue and the metrics of one episode, rebuilt from what the world publishes.

    Feed it the cleaning events and the poses in the order they arrive. A sample is due at the
    first pose at or after each sample boundary; it is taken once a later pose arrives and
    every cleaning event stamped up to the sampled pose is known to be in (``confirmed_ns``;
    or at :meth:`finish`), after applying those events, so the order in which the two topics
    arrive does not matter.
    """

    def __init__(self, setup: EpisodeSetup) -> None:
        self.setup = setup
        self.field = CueField(setup.world, setup.mona, setup.sensing)
        self.initial_mean = self.field.initial_mean
        self.late_events = 0  #: cleaning events that arrived after their time was sampled
        self.poses: np.ndarray = setup.initial_poses.copy()  #: the latest poses
        self._events: list[tuple[int, np.ndarray]] = []
        self._pending: collections.deque[tuple[int, int, np.ndarray]] = collections.deque()
        #: Every cleaning event stamped up to here has been fed. Offline (a bag read in time
        #: order) that is always so; online the recorder moves it with the world's status,
        #: which counts the cleaning events: the two topics arrive in no fixed order.
        self.confirmed_ns = NEVER
        self._last_pose_ns = setup.start_ns
        self._sampled_ns = setup.start_ns

    def initial(self) -> tuple[int, dict[str, float]]:
        """The t = 0 row (initial cue, announced poses) and its log time."""
        return self.setup.start_ns, self._row(0, self.setup.initial_poses)

    def cleaning(self, time_ns: int, poses: np.ndarray) -> None:
        """A /world/cleaning event: the robots (poses [M, 3]) that cleaned at ``time_ns``."""
        if time_ns <= self._sampled_ns:
            self.late_events += 1
        self._events.append((time_ns, poses))

    def due(self, time_ns: int) -> bool:
        """True if a pose stamped ``time_ns`` is the first at or after a sample boundary."""
        start = self.setup.start_ns
        return crossed(self._last_pose_ns - start, time_ns - start, self.setup.sample_ns)

    def pose(self, time_ns: int,
             poses: np.ndarray | None) -> tuple[list[tuple[int, dict[str, float]]], bool]:
        """A /world/poses message. Returns (rows now complete, whether this pose is sampled).

        ``poses`` [N, 3] may be None for a pose that is not :meth:`due` (saves decoding it).
        """
        rows = self.advance(time_ns - 1)
        due = self.due(time_ns)
        self._last_pose_ns = max(self._last_pose_ns, time_ns)
        if poses is not None:
            self.poses = poses
        if due:
            if poses is None:
                raise ValueError('a sampled pose needs its poses')
            k = (time_ns - self.setup.start_ns) // self.setup.sample_ns
            self._pending.append((time_ns, k, poses))
        return rows, due

    def advance(self, time_ns: int) -> list[tuple[int, dict[str, float]]]:
        """Take the pending samples stamped at or before ``time_ns`` (and ``confirmed_ns``)."""
        limit = min(time_ns, self.confirmed_ns)
        rows = []
        while self._pending and self._pending[0][0] <= limit:
            stamp, k, poses = self._pending.popleft()
            self.cue_at(stamp)
            self._sampled_ns = stamp
            rows.append((self.setup.start_ns + k * self.setup.sample_ns, self._row(k, poses)))
        return rows

    @property
    def pending_poses(self) -> np.ndarray:
        """The poses of the sample :meth:`advance` would take next (else the latest poses)."""
        return self._pending[0][2] if self._pending else self.poses

    def finish(self) -> list[tuple[int, dict[str, float]]]:
        """Take every pending sample (the world has finished or gone: nothing more comes)."""
        self.confirmed_ns = NEVER
        return self.advance(NEVER)

    @property
    def cue(self) -> np.ndarray:
        """The rebuilt cue as far as :meth:`cue_at` has taken it."""
        return self.field.cue

    def cue_at(self, time_ns: int) -> np.ndarray:
        """The cue at ``time_ns``: every cleaning event stamped up to it applied in order, each
        after the transport ticks of the steps before its own (as the world steps)."""
        due = [event for event in self._events if event[0] <= time_ns]
        start = self.setup.start_ns
        if due:
            self._events = [event for event in self._events if event[0] > time_ns]
            for stamp, poses in sorted(due, key=lambda event: event[0]):
                self.field.clean_at(stamp - start, poses)
        self.field.advance_to(min(time_ns, self.setup.end_ns) - start)  # NEVER: the end
        return self.field.cue

    def _row(self, k: int, poses: np.ndarray) -> dict[str, float]:
        return sample_field(k * self.setup.metrics.sample_period, self.field, poses[:, :2],
                            self.setup.metrics)


@dataclasses.dataclass
class Recomputation:
    """The metrics of one episode recomputed from its bag, and how they compare."""

    setup: EpisodeSetup
    rows: list[dict[str, float]]  #: metrics.csv rows
    final_cue: np.ndarray
    final_poses: np.ndarray
    online_rows: int  #: samples the metrics node recorded
    online_max_diff: float | None  #: max |online - offline| over matched samples (None: none)
    cue_maps_checked: int  #: recorded /world/cue_map images compared with the rebuilt cue
    cue_map_max_diff: int  #: max |map - rint(rebuilt cue)| over them (cue units)
    last_status: dict[str, Any] | None  #: the world's final /world/status
    snapshots: dict[float, tuple[np.ndarray, np.ndarray]]  #: t -> (cue, poses)
    cue_maps_differing: int = 0  #: how many of the checked cue maps differ at all
    cue_map_first_diff_ns: int | None = None  #: log time of the first map that differs
    #: (log time, metric) of the first online sample that differs from the recomputation
    online_first_diff: tuple[int, str] | None = None

    @property
    def covered(self) -> float:
        """Sim seconds covered by the samples (the last row's t)."""
        return self.rows[-1]['t'] if self.rows else 0.0

    @property
    def complete(self) -> bool:
        """True when the samples reach the episode's duration."""
        return self.covered + self.setup.metrics.sample_period > self.setup.duration


def episode_setup(bag: EpisodeBag) -> EpisodeSetup:
    """The setup announced in a bag.

    Raises:
        BagError: the bag has no usable /episode announcement.
    """
    if bag.announcement is None:
        raise BagError(f"{bag.path} holds no /episode announcement, so the episode's seed, "
                       f'initial poses and parameters are unknown (custom_data: '
                       f'{sorted(bag.custom) or "none"}); it holds {bag.report.readable()}')
    try:
        return EpisodeSetup.from_announcement(bag.announcement)
    except AnnouncementError as error:
        raise BagError(f'{bag.path}: {error}') from None


def recompute(bag: EpisodeBag, snapshot_times: tuple[float, ...] = ()) -> Recomputation:
    """Every metric of the episode from its bag (see the module docstring).

    Args:
        snapshot_times: sim times (s) at which to keep the rebuilt cue and the poses, each at
            the first sample at or after it (as the embedded runner keeps them).

    Raises:
        BagError: no usable announcement, or poses that do not match the population.
    """
    setup = episode_setup(bag)
    replica = MetricsReplica(setup)
    # Log-time order; at equal times cleaning first, then poses, then maps: the world cleans
    # within the step whose poses it then publishes.
    events: list[tuple[int, int, Any]] = [(t, 0, p) for t, p in bag.cleaning]
    events += [(t, 1, p) for t, p in bag.poses if t > setup.start_ns]
    events += [(t, 2, m) for t, m in bag.cue_maps if t >= setup.start_ns]
    events.sort(key=lambda event: (event[0], event[1]))
    pending = sorted(snapshot_times)
    snapshots: dict[float, tuple[np.ndarray, np.ndarray]] = {}
    timed: list[tuple[int, dict[str, float]]] = []

    def keep(rows: list[tuple[int, dict[str, float]]], poses: np.ndarray) -> None:
        for row in rows:
            timed.append(row)
            while pending and pending[0] <= row[1]['t'] + 1e-9:
                snapshots[pending.pop(0)] = (replica.cue.copy(), poses.copy())

    keep([replica.initial()], setup.initial_poses)
    checked, worst, differing, first_diff = 0, 0, 0, None
    for time_ns, kind, payload in events:
        if kind == 0:
            replica.cleaning(time_ns, payload)
        elif kind == 1:
            if len(payload) != setup.population:
                raise BagError(f'{bag.path}: /world/poses at {time_ns / 1e9:.3f} s has '
                               f'{len(payload)} robots, the episode {setup.population}')
            before = replica.pending_poses
            keep(replica.pose(time_ns, payload)[0], before)
        else:
            keep(replica.advance(time_ns), replica.pending_poses)
            cue = replica.cue_at(time_ns)
            if payload.shape == cue.shape:
                difference = np.abs(payload.astype(np.int16)
                                    - np.rint(cue).astype(np.int16)).max()
                checked, worst = checked + 1, max(worst, int(difference))
                if difference:
                    differing += 1
                    first_diff = time_ns if first_diff is None else first_diff
            else:
                raise BagError(f'{bag.path}: /world/cue_map is {payload.shape}, the '
                               f'parameters give {cue.shape}')
    keep(replica.finish(), replica.pending_poses)
    online, diff, online_first = _compare_online(bag, timed)
    return Recomputation(setup, [row for _, row in timed], replica.cue_at(NEVER).copy(),
                         replica.poses.copy(), online, diff, checked, worst,
                         bag.status[-1][1] if bag.status else None, snapshots,
                         differing, first_diff, online_first)


def _compare_online(bag: EpisodeBag, timed: list[tuple[int, dict[str, float]]]
                    ) -> tuple[int, float | None, tuple[int, str] | None]:
    """(online samples, max |online - offline| over the samples both have, (log time, metric)
    of the first sample that differs)."""
    offline = dict(timed)
    names = metric_names()
    worst, matched, first = None, 0, None
    for name in names:
        for t, value in bag.metrics.get(name, []):
            if t in offline:
                mine = offline[t][name]
                if math.isnan(value) and math.isnan(mine):
                    difference = 0.0
                else:
                    difference = abs(value - mine)
                    difference = math.inf if math.isnan(difference) else difference
                worst = difference if worst is None else max(worst, difference)
                matched += 1
                if difference and (first is None or t < first[0]):
                    first = (t, name)
    online = max((len(bag.metrics.get(name, [])) for name in names), default=0)
    return online, (worst if matched else None), first

