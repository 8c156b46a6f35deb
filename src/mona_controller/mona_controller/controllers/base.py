"""The controller seam: what every Mona controller is, its states, and how a kind is built.

A controller maps each robot's readings and sim time to its wheel and cleaner commands (the
VMAS contract, ``compute_action(observation) -> action``, for N robots at once). The engine,
the batched engine and the controller node drive any :class:`Controller` alike;
``controller.kind`` names which one (:mod:`.registry`), :func:`make_controller` builds it.
A kind is one class: it declares its own parameters (``Params``, the section
``controller.<kind>.*``) and its behaviour states (:attr:`Controller.STATES`, the names and
colours every observer shows). BEECLUST (:mod:`.beeclust`) is the first kind;
:mod:`.reference` holds its plain-Python reference and the check that a fast implementation
follows it.

Adding a controller: write one :class:`Controller` subclass (its docstring lists what is
compulsory), add one line to :data:`~.registry.CONTROLLERS`, and run the conformance tests
(tests/unit/test_controllers.py runs every registered kind).
"""

from __future__ import annotations

import abc
import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, Self

import numpy as np

from mona_controller.controllers import registry
from mona_controller.controllers.params import DEFAULT_KIND, ControllerParams
from mona_controller.mona import MonaParams

#: An RGBA colour, each channel in [0, 1].
Colour = tuple[float, float, float, float]


@dataclasses.dataclass(frozen=True)
class State:
    """A behaviour state of a controller kind, as observers show it (markers, videos, the
    Foxglove layout): its code is its index in the kind's :attr:`Controller.STATES`."""

    name: str  #: e.g. 'follow'
    colour: Colour  #: RGBA in [0, 1]

    def __post_init__(self) -> None:
        if not self.name or len(self.colour) != 4 or \
                not all(0.0 <= channel <= 1.0 for channel in self.colour):
            raise ValueError(f'state {self.name!r}: a name and an RGBA colour in [0, 1], not '
                             f'{self.colour!r}')


@dataclasses.dataclass
class Command:
    """What the controllers answer for one step."""

    wheels: np.ndarray  #: [N, 2] float64, left and right wheel commands (wheel units)
    cleaner: np.ndarray  #: [N] bool, the cleaning actuator


class Controller(abc.ABC):
    """The controllers of the robots ``robot_ids``: readings and sim time in, commands out.

    An abstract base class rather than a ``typing.Protocol``: :meth:`merge` is the same for
    every kind (driven by :attr:`PER_ROBOT`) and is inherited, not rewritten, and a class
    missing a compulsory method fails when it is built, not at its first step. It adds
    nothing to a step: :meth:`step` is the subclass's own method.

    Compulsory in a subclass:

    - :attr:`STATES`: its behaviour states (:class:`State`, a name and a colour each); code
      i of ``state`` is ``STATES[i]``, which markers, bags, videos and the Foxglove layout
      show.
    - ``__init__(params, mona, robot_ids)`` that calls ``super().__init__(params, mona,
      robot_ids)`` (which sets the attributes below and calls :meth:`derive`), then creates
      its own per-robot state.
    - :meth:`reset` and :meth:`step`.
    - :attr:`PER_ROBOT` naming every per-robot attribute it adds (arrays and lists over its
      robots, in robot order), after those of this class.
    - ``state``: one int8 code per robot, an index of :attr:`STATES`. ``encounters``: int64
      per robot, the robot meetings it counted (0 if it counts none).

    Optional: :attr:`Params`, a frozen dataclass of its own parameters (fields made with
    :func:`~mona_controller.schema.param`, validated in ``__post_init__`` with the prefix
    ``controller.<kind>.``; a ``check(controller)`` method may check them against the whole
    ``controller`` section). Every ``ControllerParams`` then holds one, read as
    ``params.<kind>`` or, typed, ``params.section(Params)``.
    Also optional: :meth:`derive`, for whatever follows from the parameters alone (per-robot
    constants, lookup tables); it is called by ``__init__`` and by :meth:`merge`.

    Every instance attribute must be named in :attr:`PER_ROBOT`, be one of the parameter
    attributes below, or be set by :meth:`derive`: :meth:`merge` refuses a class whose parts
    have an attribute the merged controller lacks.

    Attributes:
        robot_ids: [N] int64, the robots' ids (their generators are seeded from them).
        params: the parameter sets (``ControllerParams``) the robots run, each once.
        mona: the Mona descriptions (``MonaParams``), one per entry of ``params``.
        param_index: [N] intp, robot i runs ``params[param_index[i]]`` on
            ``mona[param_index[i]]``. A lone controller has one set (index 0 for all); a
            merged one has its parts' sets.
        state: [N] int8 behaviour codes.
        encounters: [N] int64 robot meetings.
    """

    #: The per-robot attributes :meth:`merge` joins, in one list: arrays are concatenated and
    #: the parts keep views of their rows; lists are concatenated (their items shared).
    PER_ROBOT: ClassVar[tuple[str, ...]] = ('robot_ids', 'state', 'encounters')
    #: The behaviour states, by code (compulsory: a kind without states has nothing to show).
    STATES: ClassVar[tuple[State, ...]] = ()
    #: The kind's own parameter section (``controller.<kind>.*``); None: it has none.
    Params: ClassVar[type | None] = None

    def __init__(self, params: ControllerParams, mona: MonaParams,
                 robot_ids: Sequence[int]) -> None:
        """Hold the robots ``robot_ids`` running ``params`` on ``mona``, then :meth:`derive`.

        Args:
            params: the ``controller`` section.
            mona: the robots' geometry and sensors.
            robot_ids: the robots' ids, in the order of the readings' rows.
        """
        self.robot_ids = np.asarray(robot_ids, dtype=np.int64)
        n = len(self.robot_ids)
        self.params: tuple[ControllerParams, ...] = (params,)
        self.mona: tuple[MonaParams, ...] = (mona,)
        self.param_index = np.zeros(n, dtype=np.intp)
        self.state = np.zeros(n, dtype=np.int8)
        self.encounters = np.zeros(n, dtype=np.int64)
        self.derive()

    @abc.abstractmethod
    def reset(self, seed: int) -> None:
        """Start a new episode with this seed: every robot's state and generator afresh.

        Robot i draws only from ``default_rng([seed, CONTROLLER_STREAM, robot_ids[i]])``
        (docs/architecture.md, Randomness), so it behaves alike in any runner or batch.
        """

    @abc.abstractmethod
    def step(self, ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray,
             now: float | np.ndarray) -> Command:
        """Advance every robot's behaviour and answer its wheel and cleaner commands.

        Args:
            ground: [N, 2] uint8 ground readings (left, right), 0..255.
            ranges: [N, K] float32 IR ranges from the body edge (m); inf where nothing is
                seen.
            is_robot: [N, K] bool, True where the obstacle seen is a robot.
            now: sim time of the readings (s); or [N] float64, each robot's (a merged
                controller steps episodes with their own clocks).

        Returns:
            Each robot's wheels [N, 2] float64 (wheel units) and cleaner [N] bool.
        """

    def derive(self) -> None:  # noqa: B027 (an optional hook, empty by default)
        """Work out what follows from ``params``, ``mona`` and ``param_index`` alone (called
        by ``__init__`` and :meth:`merge`). Nothing here."""

    @classmethod
    def merge(cls, parts: Sequence[Self]) -> Self:
        """One controller stepping the robots of all ``parts``, in order (the batched engine).

        Each robot keeps its own parameter set and generator, so it computes exactly what it
        computes alone. The parts take over: their generators are shared, and their
        :attr:`PER_ROBOT` arrays become views of the merged ones, so each part still shows
        its robots' state to observers, and a part can be merged again (into another batch)
        once this one is no longer stepped. The merged controller's :meth:`step` takes
        ``now`` per robot (each part's own time); its :meth:`reset` reseeds all robots from
        one seed.

        Raises:
            ValueError: no parts.
            TypeError: a part is of another kind, or the class has a per-robot attribute
                that is missing from :attr:`PER_ROBOT` (and not set by :meth:`derive`).
        """
        if not parts:
            raise ValueError(f'{cls.__name__}.merge needs at least one controller')
        for part in parts:
            if type(part) is not cls:
                raise TypeError(f'{cls.__name__}.merge cannot join a {type(part).__name__}: '
                                'one merged controller steps robots of one kind')
        merged = cls.__new__(cls)
        # The parameter sets, each once (one in a uniform batch), and each robot's.
        sets = list(dict.fromkeys(pair for part in parts
                                  for pair in zip(part.params, part.mona)))
        merged.params = tuple(params for params, _ in sets)
        merged.mona = tuple(mona for _, mona in sets)
        merged.param_index = np.concatenate([
            np.array([sets.index(pair) for pair in zip(part.params, part.mona)],
                     dtype=np.intp)[part.param_index] for part in parts])
        bounds = np.cumsum([0] + [len(part.robot_ids) for part in parts]).tolist()
        for name in cls.PER_ROBOT:
            values = [getattr(part, name) for part in parts]
            joined: np.ndarray | list[Any]
            if isinstance(values[0], np.ndarray):
                joined = np.concatenate(values)
                for part, start, stop in zip(parts, bounds, bounds[1:]):
                    setattr(part, name, joined[start:stop])  # the part sees its rows
            else:
                joined = [item for value in values for item in value]
            if len(joined) != bounds[-1]:
                raise TypeError(f'{cls.__name__}.{name} is in PER_ROBOT but has '
                                f'{len(joined)} items for {bounds[-1]} robots')
            setattr(merged, name, joined)
        merged.derive()
        missing = sorted(vars(parts[0]).keys() - vars(merged).keys())
        if missing:
            raise TypeError(f'{cls.__name__}.merge would lose {", ".join(missing)}: name '
                            'every per-robot attribute in PER_ROBOT, or set it in derive()')
        return merged


def controller_class(kind: str) -> type[Controller]:
    """The class registered as ``kind`` (imported on first use).

    Raises:
        KeyError: no such kind (``ControllerParams`` refuses one when it is built).
        TypeError: the registered class is not a :class:`Controller` with states.
    """
    cls = registry.load(kind)
    if not (isinstance(cls, type) and issubclass(cls, Controller) and cls.STATES):
        raise TypeError(f'controller kind {kind!r} ({registry.CONTROLLERS[kind]}) is not a '
                        'Controller subclass with STATES')
    return cls


def states_of(kind: str) -> tuple[State, ...]:
    """The behaviour states of the kind ``kind``, by code (what observers show).

    Raises:
        KeyError: the kind is not registered in this process.
    """
    if kind not in registry.CONTROLLERS:
        raise KeyError(f'controller.kind {kind!r} is not registered in this process (one of '
                       f'{", ".join(map(repr, registry.CONTROLLERS))})')
    return controller_class(kind).STATES


def states_for(parameters: Mapping[str, Any]) -> tuple[State, ...]:
    """The states of the kind that a mapping of parameters names (an announcement's, a
    record's: ``controller.kind``; the default kind where it names none).

    Raises:
        KeyError: the kind is not registered in this process.
    """
    section = parameters.get('controller')
    kind = section.get('kind', DEFAULT_KIND) if isinstance(section, Mapping) else DEFAULT_KIND
    return states_of(str(kind))


def make_controller(params: ControllerParams, mona: MonaParams,
                    robot_ids: Sequence[int]) -> Controller:
    """The controller of kind ``params.kind`` for the robots ``robot_ids``.

    Raises:
        ParameterError: the parameters do not fit the controller (e.g. a speed beyond the
            wheels' top command).
    """
    return controller_class(params.kind)(params, mona, robot_ids)
