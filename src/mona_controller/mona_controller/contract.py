"""The topic contract as plain Python: the frames, world states, the episode announcement and
the recorder protocol.

ROS-free, so that bag tools, analysis and tests use the very names and records the nodes use.
The topics themselves (name, type, QoS, publisher, what a bag records) are one table,
:data:`mona_controller.topics.TOPICS`, with the topic names; :mod:`mona_controller.ros.qos`
builds the rclpy profiles from it. The page that explains it is docs/interfaces.md.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
import warnings
from collections.abc import Iterable
from typing import Any, cast

from mona_controller import topics
from mona_controller.controllers.base import Colour, State, states_for

#: Robot poses as an announcement carries them: (x m, y m, yaw rad) per robot.
Poses = tuple[tuple[float, float, float], ...]
#: The world frame (REP 103: origin at an arena corner, x and y along the walls).
WORLD_FRAME = 'world'


def base_frame(robot_id: int) -> str:
    """The body frame of robot ``robot_id``."""
    return f'mona_{robot_id}/base_link'


class WorldState(str, enum.Enum):
    """The ``state`` of /world/status."""

    WAITING = 'waiting'  #: no episode, or the episode waits for its controllers and recorders
    RUNNING = 'running'
    FINISHED = 'finished'
    FAILED = 'failed'


class RecorderState(str, enum.Enum):
    """What a recorder says of an episode on /recorders."""

    RECORDING = 'recording'  #: its record of the episode is open and listening
    CLOSED = 'closed'  #: its record is closed (``complete`` says whether it has everything)


class ContractError(ValueError):
    """A message that does not follow docs/interfaces.md."""


@dataclasses.dataclass(frozen=True)
class WorldStatus:
    """The world's /world/status message (std_msgs/String JSON).

    Readers take what they need; a status from a world that does not count something (a real
    robot's driver) leaves it at its default (``cleaning_events`` None: not counted).
    """

    episode: int  #: -1 before the first episode
    state: WorldState
    step: int = 0  #: steps done in the episode
    steps: int = 0  #: the episode's step count
    time_ns: int = 0  #: sim time now (monotonic across episodes)
    mode: str = 'lockstep'
    misses: tuple[int, ...] = ()  #: per robot
    absent: tuple[int, ...] = ()  #: robot ids
    dropped: int = 0  #: commands stamped for another step
    duplicates: int = 0
    cleaning_events: int | None = None  #: /world/cleaning messages of the episode so far
    error: str = ''

    @property
    def ended(self) -> bool:
        """The episode is over, finished or failed."""
        return self.state in (WorldState.FINISHED, WorldState.FAILED)

    def to_json(self) -> str:
        """The message text."""
        document = dataclasses.asdict(self)
        document.update(state=self.state.value, misses=list(self.misses),
                        absent=list(self.absent))
        return json.dumps(document)

    @classmethod
    def from_dict(cls, document: dict[str, Any]) -> WorldStatus:
        """Parse a decoded status.

        Raises:
            ContractError: naming the missing field or the bad value.
        """
        try:
            counted = document.get('cleaning_events')
            return cls(episode=int(document['episode']), state=WorldState(document['state']),
                       step=int(document.get('step', 0)), steps=int(document.get('steps', 0)),
                       time_ns=int(document.get('time_ns', 0)),
                       mode=str(document.get('mode', 'lockstep')),
                       misses=tuple(int(m) for m in document.get('misses', ())),
                       absent=tuple(int(a) for a in document.get('absent', ())),
                       dropped=int(document.get('dropped', 0)),
                       duplicates=int(document.get('duplicates', 0)),
                       cleaning_events=None if counted is None else int(counted),
                       error=str(document.get('error') or ''))
        except KeyError as error:
            raise ContractError(f'a /world/status without {error.args[0]!r}') from None
        except (ValueError, TypeError, AttributeError) as error:
            raise ContractError(f'a malformed /world/status ({error})') from None

    @classmethod
    def from_json(cls, text: str) -> WorldStatus:
        """Parse a /world/status message.

        Raises:
            ContractError: not a JSON object, or as :meth:`from_dict`.
        """
        try:
            document = json.loads(text)
        except ValueError as error:
            raise ContractError(f'/world/status is not JSON ({error}): {text[:200]}') from None
        if not isinstance(document, dict):
            raise ContractError(f'/world/status is not a JSON object: {text[:200]}')
        return cls.from_dict(document)


@dataclasses.dataclass(frozen=True)
class RecorderReport:
    """One recorder's word on one episode (/recorders, std_msgs/String JSON).

    A recorder (the metrics node) says ``recording`` once the episode's bag is open and its
    subscriptions to the world's topics are matched (``recorded_ns`` = ``start_ns - 1``); the
    world publishes the episode's start only then. While recording it repeats the report with
    ``recorded_ns``, the sim time up to which its record is whole: the world takes its first
    step once that reaches ``start_ns`` (the start is recorded) and never runs more than
    ``recorder_lag`` ahead of it. ``closed`` ends the episode's record, with ``complete`` and
    the ``problems`` found if it is not (the completeness verdict on the bag).
    """

    recorder: str  #: the recorder's node name, as the world's ``recorders`` parameter lists it
    episode: int
    start_ns: int  #: the announced start of the episode (tells two runs' episode k apart)
    state: RecorderState
    recorded_ns: int = 0  #: sim time up to which the record is whole
    complete: bool = False  #: with CLOSED: the record holds the whole episode
    problems: tuple[str, ...] = ()  #: with CLOSED: what is missing, if anything
    path: str = ''  #: where the record is (the bag folder)

    def to_json(self) -> str:
        """The message text."""
        document = dataclasses.asdict(self)
        document['state'] = self.state.value
        document['problems'] = list(self.problems)
        return json.dumps(document)

    @classmethod
    def from_json(cls, text: str) -> RecorderReport:
        """Parse a /recorders message.

        Raises:
            ContractError: naming what is missing or of the wrong type.
        """
        try:
            document = json.loads(text)
            report = cls(recorder=str(document['recorder']), episode=int(document['episode']),
                         start_ns=int(document['start_ns']),
                         state=RecorderState(document['state']),
                         recorded_ns=int(document.get('recorded_ns', 0)),
                         complete=bool(document.get('complete', False)),
                         problems=tuple(str(p) for p in document.get('problems', ())),
                         path=str(document.get('path', '')))
        except KeyError as error:
            raise ContractError(f'a /recorders report without {error.args[0]!r}: '
                                f'{text[:200]}') from None
        except (ValueError, TypeError, AttributeError) as error:
            raise ContractError(f'a malformed /recorders report ({error}): {text[:200]}') \
                from None
        return report


@dataclasses.dataclass(frozen=True)
class Announcement:
    """The supervisor's /episode message (std_msgs/String JSON): an episode, or the shutdown.

    ``poses`` and ``parameters`` stay plain lists and mappings: each reader checks the part it
    uses (the world its own sections, the analysis every section) with the schema.
    ``states`` are the controller kind's behaviour states (name and colour, by code), so an
    observer (the world's markers, the Foxglove layout, a bag's reader) shows the codes the
    robots report without knowing the kind.
    """

    episode: int
    shutdown: bool = False  #: the run is over: every node exits
    seed: int = 0
    population: int = 0
    duration: float = 0.0  #: s of sim time
    start_ns: int = 0  #: sim time of the episode's t = 0
    poses: Poses = ()  #: [x, y, yaw] per robot, world frame
    parameters: dict[str, Any] = dataclasses.field(default_factory=dict)  #: every section
    states: tuple[State, ...] = ()  #: the kind's states, by code
    #: The plug-ins the run loaded (:meth:`mona_controller.plugins.Plugin.to_dict` records):
    #: what an analysis must load to recompute it. Left out of the message when empty.
    plugins: tuple[dict[str, Any], ...] = ()

    @property
    def key(self) -> tuple[int, int, int]:
        """(episode, seed, start_ns): the same key is the same announcement redelivered."""
        return self.episode, self.seed, self.start_ns

    def to_json(self) -> str:
        """The message text (a shutdown carries only the episode and the flag)."""
        if self.shutdown:
            return json.dumps({'episode': self.episode, 'shutdown': True})
        document = {'episode': self.episode, 'seed': self.seed,
                    'population': self.population, 'duration': self.duration,
                    'start_ns': self.start_ns, 'poses': [list(p) for p in self.poses],
                    'parameters': self.parameters,
                    'states': [{'name': state.name, 'colour': list(state.colour)}
                               for state in self.states]}
        if self.plugins:
            document['plugins'] = list(self.plugins)
        return json.dumps(document)

    @classmethod
    def from_dict(cls, document: dict[str, Any]) -> Announcement:
        """Parse a decoded announcement.

        Raises:
            ContractError: naming the missing field or the bad value.
        """
        try:
            if not isinstance(document, dict):
                raise TypeError('not a JSON object')
            if document.get('shutdown'):
                return cls(episode=int(document.get('episode', -1)), shutdown=True)
            parameters = document['parameters']
            if not isinstance(parameters, dict):
                raise TypeError("'parameters' is not a mapping")
            poses = tuple((float(x), float(y), float(yaw)) for x, y, yaw in document['poses'])
            plugins = document.get('plugins', [])
            if not isinstance(plugins, (list, tuple)) or \
                    not all(isinstance(p, dict) for p in plugins):
                raise TypeError("'plugins' is not a list of records")
            announcement = cls(episode=int(document['episode']), seed=int(document['seed']),
                               population=int(document['population']),
                               duration=float(document['duration']),
                               start_ns=int(document['start_ns']), poses=poses,
                               parameters=parameters, plugins=tuple(plugins),
                               states=tuple(State(str(state['name']), cast(
                                                  Colour, tuple(float(c) for c in
                                                                state['colour'])))
                                            for state in document.get('states', ())))
        except KeyError as error:
            raise ContractError(f'the episode announcement has no {error.args[0]!r}') from None
        except (TypeError, ValueError, OverflowError) as error:
            raise ContractError(f'bad episode announcement: {error}') from None
        problem = announcement.problem()
        if problem:
            raise ContractError(f'bad episode announcement: {problem}')
        return announcement

    @classmethod
    def from_json(cls, text: str) -> Announcement:
        """Parse a /episode message.

        Raises:
            ContractError: not JSON, or as :meth:`from_dict`.
        """
        try:
            document = json.loads(text)
        except ValueError as error:
            raise ContractError(f'the episode announcement is not JSON ({error}): '
                                f'{text[:200]}') from None
        return cls.from_dict(document)

    def robot_states(self) -> tuple[State, ...]:
        """The states the robots report, by code: those announced, or (an announcement
        without them) those of the kind its parameters name.

        Raises:
            KeyError: none announced, and the kind is not registered in this process.
        """
        return self.states or states_for(self.parameters)

    def problem(self) -> str:
        """What makes this episode unplayable ('' = nothing)."""
        if self.population < 0 or len(self.poses) != self.population:
            return f'population {self.population} but {len(self.poses)} poses'
        if not all(math.isfinite(v) for pose in self.poses for v in pose):
            return 'the poses are not all finite'
        if not (self.duration > 0 and math.isfinite(self.duration)):
            return f'duration {self.duration} s is not positive'
        if self.start_ns < 0:
            return f'start_ns {self.start_ns} is negative'
        return ''


def recorder_names(text: str) -> tuple[str, ...]:
    """The recorder names of a comma-separated parameter ('' = none)."""
    return tuple(name.strip() for name in text.split(',') if name.strip())


class RecorderBook:
    """The latest report of each expected recorder, and what they say of an episode."""

    def __init__(self, names: Iterable[str]) -> None:
        self.names = tuple(names)
        self.latest: dict[str, RecorderReport] = {}

    def update(self, report: RecorderReport) -> bool:
        """Keep ``report`` if it is from an expected recorder; True if kept."""
        if report.recorder not in self.names:
            return False
        self.latest[report.recorder] = report
        return True

    def _of(self, name: str, episode: int, start_ns: int) -> RecorderReport | None:
        report = self.latest.get(name)
        if report is None or (report.episode, report.start_ns) != (episode, start_ns):
            return None
        return report

    def not_recording(self, episode: int, start_ns: int) -> list[str]:
        """The recorders that have not said they record this episode (or closed it)."""
        return [name for name in self.names if self._of(name, episode, start_ns) is None]

    def behind(self, episode: int, start_ns: int, time_ns: int) -> list[str]:
        """The recorders whose record of this episode does not reach ``time_ns`` yet."""
        behind = []
        for name in self.names:
            report = self._of(name, episode, start_ns)
            if report is None or (report.state is RecorderState.RECORDING
                                  and report.recorded_ns < time_ns):
                behind.append(name)
        return behind

    def closed(self, episode: int, start_ns: int) -> dict[str, RecorderReport]:
        """The recorders that closed this episode's record, by name."""
        reports = {name: self._of(name, episode, start_ns) for name in self.names}
        return {name: report for name, report in reports.items()
                if report is not None and report.state is RecorderState.CLOSED}


def __getattr__(name: str) -> Any:
    """A name of the topic table (:mod:`mona_controller.topics`), which this module
    re-exported until this release: still found here for one release, with a
    DeprecationWarning."""
    if name.startswith('_') or not hasattr(topics, name):
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    warnings.warn(f'{__name__}.{name} moved to mona_controller.topics.{name}',
                  DeprecationWarning, stacklevel=2)
    return getattr(topics, name)
