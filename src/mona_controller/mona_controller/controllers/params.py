"""The ``controller`` section: the kind, the forward speed, and one sub-section per kind.

What every kind shares sits at ``controller.``: ``kind`` and ``speed`` (the study's ``speeds``
factor and the CLI's ``--speed`` set it, whatever the kind). Each kind's own parameters sit
under its name, ``controller.<kind>.*`` (``controller.beeclust.alpha``,
``controller.network.hidden``), declared by the kind's ``Params`` dataclass; the sections are
those of every kind registered when the section is built (:mod:`.registry`), each at its
defaults unless given. The keys from before the kinds had sections (``controller.alpha``,
``controller.network_hidden``, ...) still work for one release: :data:`ControllerParams.
RENAMED` maps them to their new homes, with a :class:`~mona_controller.schema.
DeprecatedKeyWarning` naming the new key.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar, TypeVar

from mona_controller.controllers import registry
from mona_controller.schema import ParameterError, param, sections, validate

T = TypeVar('T')

#: The kind a parameter set without ``controller.kind`` runs.
DEFAULT_KIND = 'beeclust'

#: BEECLUST's parameters (``controller.beeclust.*``), each also a key of ``controller.``
#: before kinds had sections.
_BEECLUST = ('alpha', 'wait_max', 'wait_half_constant', 'turn_min', 'turn_max', 'turn_speed',
             'turn_at', 'avoid')
#: The network kind's (``controller.network.*``), before: ``controller.network_<name>``.
_NETWORK = ('hidden', 'recurrent', 'weights', 'seed', 'weights_sha256', 'max_speed',
            'clean_stops')


def kind_sections() -> dict[str, type]:
    """Each registered kind that has parameters -> its ``Params`` dataclass (imports the
    kinds' modules).

    Raises:
        ParameterError: a registered kind cannot be loaded (naming it).
    """
    found = {}
    for kind in registry.CONTROLLERS:
        try:
            params = getattr(registry.load(kind), 'Params', None)
        except ImportError as error:
            raise ParameterError(str(error)) from None
        if params is not None:
            found[kind] = params
    return found


@dataclasses.dataclass(frozen=True)
class ControllerParams:
    """Parameters of the controller: its kind, its forward speed, and each kind's own section
    (controller.<kind>.*; docs/model.md, Controller)."""

    kind: str = param(DEFAULT_KIND,
                      doc="the controller, a kind of mona_controller.controllers.CONTROLLERS: "
                          "'beeclust' follows the gradient (eq. 2) and waits on meeting a "
                          "robot (eq. 1); 'network' a small neural net (docs/learned.md)")
    speed: float = param(0.08, unit='m/s', low=0.0, high=1.0,
                         doc='forward speed v_r on a clean floor (beta = speed / wheel unit)')
    kinds: tuple[tuple[str, Any], ...] = sections(
        kind_sections, doc="each kind's own parameters, under its name (controller.<kind>.*)")

    #: Keys of this section before kinds had sections -> their keys now (for one release).
    RENAMED: ClassVar[dict[str, str]] = {
        **{name: f'beeclust.{name}' for name in _BEECLUST},
        **{f'network_{name}': f'network.{name}' for name in _NETWORK}}

    def __post_init__(self) -> None:
        validate(self, 'controller.')
        if self.kind not in registry.CONTROLLERS:  # the registry may grow: checked here
            raise ParameterError(f'controller.kind = {self.kind!r} is not allowed: one of '
                                 + ', '.join(repr(kind) for kind in registry.CONTROLLERS)
                                 + ' (a kind of your own: docs/extending.md, "A controller")')
        for _, section in self.kinds:
            check = getattr(section, 'check', None)
            if check is not None:
                check(self)

    @classmethod
    def of(cls, *sections: Any, **common: Any) -> ControllerParams:
        """The section with the kinds' sections ``sections`` (the others at their defaults)
        and the ``common`` fields, e.g. ``ControllerParams.of(BeeclustParams(alpha=3.0),
        speed=0.04)``.

        Raises:
            ParameterError: a section of no registered kind, or a bad value.
        """
        names = {params: kind for kind, params in kind_sections().items()}
        try:
            given = {names[type(section)]: section for section in sections}
        except KeyError as error:
            raise ParameterError(f'{error.args[0].__name__} is the section of no registered '
                                 'controller kind') from None
        return cls(**common, kinds=tuple(given.items()))

    def __getattr__(self, name: str) -> Any:
        """A kind's section by its name: ``params.beeclust``, ``params.network``."""
        if not name.startswith('_'):  # (never while unpickling, before the fields exist)
            for kind, section in self.__dict__.get('kinds', ()):
                if kind == name:
                    return section
        raise AttributeError(f'{type(self).__name__!r} object has no attribute {name!r}')

    def section(self, cls: type[T]) -> T:
        """The section of type ``cls`` (a kind's ``Params``), typed.

        Raises:
            KeyError: no kind with this section was registered when this was built.
        """
        for _, section in self.kinds:
            if type(section) is cls:
                return section
        raise KeyError(f'no controller section of type {cls.__name__}')
