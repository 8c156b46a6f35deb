"""The controller seam: what every Mona controller is, and the registry of controller kinds.

A controller maps each robot's readings and sim time to its wheel and cleaner commands (the
VMAS contract, ``compute_action(observation) -> action``, for N robots at once). The engine,
the batched engine and the controller node drive any :class:`Controller` alike;
``controller.kind`` names which one, :data:`CONTROLLERS` maps the name to its class and
:func:`make_controller` builds it. BEECLUST (:class:`~mona_controller.controller.
SwarmController`) is the first kind; :mod:`mona_controller.reference` holds its plain-Python
reference and the check that a fast implementation follows it.

Adding a controller: write one :class:`Controller` subclass (its docstring lists what is
compulsory), add one line to :data:`CONTROLLERS`, and run the conformance tests
(tests/unit/test_controllers.py runs every registered kind).
"""

from __future__ import annotations

import abc
import dataclasses
import importlib
import importlib.metadata
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, ClassVar, Self

import numpy as np

if TYPE_CHECKING:
    from mona_controller.controller import ControllerParams
    from mona_controller.mona import MonaParams

#: Every controller kind, by the name ``controller.kind`` takes: ``'module:Class'``, imported
#: on first use, so that the parameter schema can list the kinds without importing their
#: modules (which import the schema). Adding a controller is adding one line here, or
#: :func:`register_controller`, or an entry point of :data:`ENTRY_POINTS` in one's own package.
CONTROLLERS: dict[str, str] = {
    'beeclust': 'mona_controller.controller:SwarmController',
    'network': 'mona_controller.network:NetworkController',
    'stand_net': 'mona_controller.stand_net:StandNetController',
}
#: The entry-point group through which an installed package adds controller kinds
#: (``name = 'module:Class'``): every process (a study's workers, every node) sees them.
ENTRY_POINTS = 'mona_swarm.controllers'


def register_controller(kind: str, target: str) -> None:
    """Add a controller kind, ``target`` being ``'module:Class'`` (for this process and those
    it forks; a spawned worker or a node sees it only through :data:`ENTRY_POINTS`).

    Raises:
        ValueError: the kind is taken by another class, or ``target`` is not 'module:Class'.
    """
    module, colon, name = target.partition(':')
    if not (module and colon and name.isidentifier()):
        raise ValueError(f"controller {kind!r}: {target!r} is not 'module:Class'")
    if CONTROLLERS.get(kind, target) != target:
        raise ValueError(f'controller kind {kind!r} is already {CONTROLLERS[kind]}')
    CONTROLLERS[kind] = target


for _point in importlib.metadata.entry_points(group=ENTRY_POINTS):
    CONTROLLERS.setdefault(_point.name, _point.value)


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

    - ``__init__(params, mona, robot_ids)`` that calls ``super().__init__(params, mona,
      robot_ids)`` (which sets the attributes below and calls :meth:`derive`), then creates
      its own per-robot state.
    - :meth:`reset` and :meth:`step`.
    - :attr:`PER_ROBOT` naming every per-robot attribute it adds (arrays and lists over its
      robots, in robot order), after those of this class.
    - ``state``: one int8 behaviour code per robot, for observers (markers, bags, videos
      colour robots by it): BEECLUST's ``FOLLOW, AVOID, WAIT, TURN`` (0..3,
      :mod:`mona_controller.controller`). A controller without these behaviours documents
      what it puts there. ``encounters``: int64 per robot, the robot meetings it counted
      (0 if it counts none).

    Optional: :meth:`derive`, for whatever follows from the parameters alone (per-robot
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
    """The class registered as ``kind`` in :data:`CONTROLLERS` (imported on first use).

    Raises:
        KeyError: no such kind (``ControllerParams`` refuses one when it is built).
    """
    module, _, name = CONTROLLERS[kind].partition(':')
    return getattr(importlib.import_module(module), name)


def make_controller(params: ControllerParams, mona: MonaParams,
                    robot_ids: Sequence[int]) -> Controller:
    """The controller of kind ``params.kind`` for the robots ``robot_ids``.

    Raises:
        ParameterError: the parameters do not fit the controller (e.g. a speed beyond the
            wheels' top command).
    """
    return controller_class(params.kind)(params, mona, robot_ids)
