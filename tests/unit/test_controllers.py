"""The controller seam: the registry, merge, states and parameter sections, for every
registered controller kind.

A new kind in CONTROLLERS gets these tests for free: it is built from its parameters, it
declares its states and reports only their codes, its parameters are a section of their own,
a merged controller has every attribute a lone one has, and stepping the merged controller
equals stepping each part alone (parts with different parameters and clocks).
"""

import dataclasses

import numpy as np
import pytest

from mona_controller.controllers import (
    CONTROLLERS,
    BeeclustParams,
    Command,
    Controller,
    ControllerParams,
    State,
    SwarmController,
    controller_class,
    make_controller,
    random_readings,
    register_controller,
    states_for,
    states_of,
)
from mona_controller.mappings import from_mapping, to_mapping
from mona_controller.mona import MonaParams
from mona_controller.schema import ParameterError, param, validate

KINDS = sorted(CONTROLLERS)
K = MonaParams().ir_count

#: The parts of a merged controller: parameters (of each kind), Mona, robots.
PARTS = [
    (ControllerParams(), MonaParams(), 3),
    (ControllerParams.of(BeeclustParams(wait_max=1.0, avoid='random-turn')), MonaParams(), 2),
    (ControllerParams.of(BeeclustParams(alpha=3.0, wait_max=2.0, turn_min=0.5, turn_max=1.0),
                         speed=0.04), MonaParams(ir_span=2.0), 4),
    (ControllerParams.of(BeeclustParams(wait_max=0.5, wait_half_constant=900.0,
                                        turn_speed=0.1)),
     MonaParams(ir_span=3.0, max_wheel_command=7.0), 1),
    (ControllerParams.of(BeeclustParams(alpha=0.5, wait_max=3.0), speed=0.1),
     MonaParams(ir_span=1.234), 5),
]
COUNTS = [n for _, _, n in PARTS]
BOUNDS = np.cumsum([0, *COUNTS])


def make_parts(kind, seed=0):
    parts = []
    for k, (params, mona, n) in enumerate(PARTS):
        part = make_controller(dataclasses.replace(params, kind=kind), mona,
                               range(BOUNDS[k], BOUNDS[k] + n))
        part.reset(seed)
        parts.append(part)
    return parts


def snapshot(value):
    """A per-robot attribute as comparable values (generators by their state)."""
    if isinstance(value, np.ndarray):
        return value.tobytes(), value.dtype
    return [item.bit_generator.state if isinstance(item, np.random.Generator) else item
            for item in value]


def test_the_default_kind_is_beeclust_and_an_unknown_one_is_refused():
    assert ControllerParams().kind == 'beeclust'
    assert controller_class('beeclust') is SwarmController
    assert type(make_controller(ControllerParams(), MonaParams(), [4])) is SwarmController
    with pytest.raises(ParameterError, match="controller.kind = 'neural' is not allowed: "
                                             "one of 'beeclust'"):
        ControllerParams(kind='neural')


@pytest.mark.parametrize('kind', KINDS)
def test_the_registry_builds_each_kind_from_its_parameters(kind):
    cls = controller_class(kind)
    assert issubclass(cls, Controller)
    controller = make_controller(ControllerParams(kind=kind), MonaParams(), [7, 2, 5])
    assert type(controller) is cls
    assert controller.robot_ids.tolist() == [7, 2, 5]
    assert controller.state.dtype == np.int8 and controller.encounters.dtype == np.int64
    assert controller.params == (ControllerParams(kind=kind),)
    assert controller.mona == (MonaParams(),) and controller.param_index.tolist() == [0] * 3
    command = controller.step(np.zeros((3, 2), dtype=np.uint8),
                              np.full((3, K), np.inf, dtype=np.float32),
                              np.zeros((3, K), dtype=bool), 0.0)
    assert command.wheels.shape == (3, 2) and command.wheels.dtype == np.float64
    assert command.cleaner.shape == (3,) and command.cleaner.dtype == bool


@pytest.mark.parametrize('kind', KINDS)
def test_a_merged_controller_has_every_attribute_of_a_lone_one(kind):
    parts = make_parts(kind)
    lone = dict(vars(parts[0]))
    merged = controller_class(kind).merge(parts)
    assert vars(merged).keys() == lone.keys()
    for name, value in lone.items():
        got = getattr(merged, name)
        assert type(got) is type(value), name
        if isinstance(value, np.ndarray):
            assert got.dtype == value.dtype and got.ndim == value.ndim, name
        elif isinstance(value, (list, tuple)) and value:
            assert {type(item) for item in got} == {type(value[0])}, name
    for name in merged.PER_ROBOT:
        assert len(getattr(merged, name)) == sum(COUNTS), name
    # The parameter sets, each once, and each robot's index into them.
    assert merged.params == tuple(dataclasses.replace(p, kind=kind) for p, _, _ in PARTS)
    assert merged.mona == tuple(mona for _, mona, _ in PARTS)
    assert merged.param_index.tolist() == np.repeat(range(len(PARTS)), COUNTS).tolist()


@pytest.mark.parametrize('kind', KINDS)
@pytest.mark.parametrize('seed', [2, 5])
def test_merging_then_stepping_equals_stepping_each_part_alone(kind, seed):
    rng = np.random.default_rng(seed)
    alone = make_parts(kind, seed)
    joined = make_parts(kind, seed)
    merged = controller_class(kind).merge(joined)
    starts = rng.uniform(0.0, 100.0, len(PARTS)).round(2)  # each part its own clock
    for step in range(400):
        ground, ranges, is_robot = random_readings(rng, sum(COUNTS), K)
        now = np.repeat(starts + step * 0.25, COUNTS)
        command = merged.step(ground, ranges, is_robot, now)
        for k, (part, view) in enumerate(zip(alone, joined)):
            rows = slice(BOUNDS[k], BOUNDS[k + 1])
            own = part.step(ground[rows], ranges[rows], is_robot[rows], float(now[rows][0]))
            assert own.wheels.tobytes() == command.wheels[rows].tobytes(), (step, k)
            assert own.cleaner.tobytes() == command.cleaner[rows].tobytes(), (step, k)
            for name in merged.PER_ROBOT:
                expected = snapshot(getattr(part, name))
                assert snapshot(getattr(merged, name)[rows]) == expected, (step, k, name)
                assert snapshot(getattr(view, name)) == expected, (step, k, name)


class Forgetful(SwarmController):
    """BEECLUST with one more per-robot array that PER_ROBOT does not name."""

    def __init__(self, params, mona, robot_ids):
        super().__init__(params, mona, robot_ids)
        self.last_seen = np.zeros(len(self.robot_ids))


class Declared(Forgetful):
    PER_ROBOT = (*SwarmController.PER_ROBOT, 'last_seen')


def test_a_per_robot_attribute_left_out_of_the_list_is_refused():
    params, mona = ControllerParams(), MonaParams()
    with pytest.raises(TypeError, match='would lose last_seen'):
        Forgetful.merge([Forgetful(params, mona, range(2)), Forgetful(params, mona, range(3))])
    parts = [Declared(params, mona, range(2)), Declared(params, mona, range(3))]
    parts[1].last_seen[:] = 4.0
    merged = Declared.merge(parts)
    assert merged.last_seen.tolist() == [0.0, 0.0, 4.0, 4.0, 4.0]
    with pytest.raises(TypeError, match='one kind'):
        SwarmController.merge([SwarmController(params, mona, range(2)), parts[0]])
    with pytest.raises(ValueError, match='at least one'):
        SwarmController.merge([])


@pytest.mark.parametrize('kind', KINDS)
def test_each_kind_declares_its_states_and_reports_only_their_codes(kind):
    cls = controller_class(kind)
    names = [state.name for state in cls.STATES]
    assert names and len(set(names)) == len(names) <= 256
    assert states_of(kind) == cls.STATES
    controller = make_controller(ControllerParams(kind=kind), MonaParams(), range(20))
    rng = np.random.default_rng(4)
    seen = set()
    for step in range(300):
        controller.step(*random_readings(rng, 20, K), step * 0.25)
        seen |= set(controller.state.tolist())
    assert seen <= set(range(len(cls.STATES))) and len(seen) > 1, seen


@pytest.mark.parametrize('kind', KINDS)
def test_each_kinds_parameters_are_a_section_of_their_own(kind):
    params = controller_class(kind).Params
    if params is None:
        return
    assert dataclasses.is_dataclass(params) and params.__dataclass_params__.frozen
    default = params()
    assert getattr(ControllerParams(), kind) == default == ControllerParams().section(params)
    built = from_mapping(ControllerParams, {kind: to_mapping(default)})
    assert built == ControllerParams() and hash(built) == hash(ControllerParams())
    first = dataclasses.fields(params)[0].name
    with pytest.raises(ParameterError, match=f'controller.{kind}.{first}'):
        from_mapping(ControllerParams, {kind: {first: [object()]}})


def test_a_kind_registered_at_run_time_gets_its_section_from_then_on():
    before = ControllerParams()
    register_controller('turning', f'{__name__}:Turning')
    try:
        after = ControllerParams(kind='turning')
        assert after.turning == TurningParams() and not hasattr(before, 'turning')
        assert after.section(TurningParams).rate == 1.0
        controller = make_controller(after, MonaParams(), range(3))
        controller.step(np.zeros((3, 2), np.uint8), np.full((3, K), np.inf, np.float32),
                        np.zeros((3, K), bool), 0.0)
        assert controller.state.tolist() == [1, 1, 1]
        assert states_for({'controller': {'kind': 'turning'}})[1].name == 'spinning'
    finally:
        del CONTROLLERS['turning']
    with pytest.raises(KeyError, match="controller.kind 'turning' is not registered"):
        states_of('turning')
    with pytest.raises(ValueError, match='is already'):
        register_controller('beeclust', f'{__name__}:Turning')


@dataclasses.dataclass(frozen=True)
class TurningParams:
    """A kind's own section: one parameter."""

    rate: float = param(1.0, low=0.0, high=2.0, doc='turn rate command')

    def __post_init__(self):
        validate(self, 'controller.turning.')


class Turning(Controller):
    """A kind with a parameter and two states of its own: it spins at its rate."""

    Params = TurningParams
    STATES = (State('resting', (0.5, 0.5, 0.5, 1.0)), State('spinning', (0.0, 0.0, 1.0, 1.0)))

    def reset(self, seed):
        self.state[:] = 0

    def step(self, ground, ranges, is_robot, now):
        rate = np.array([self.params[k].turning.rate for k in self.param_index])
        self.state[:] = 1
        return Command(np.stack([-rate, rate], axis=1), np.zeros(len(rate), dtype=bool))


def test_the_modules_that_moved_keep_their_old_names_for_a_release():
    with pytest.warns(DeprecationWarning, match='mona_controller.controller.FOLLOW moved to '
                                                'mona_controller.controllers.beeclust.FOLLOW'):
        from mona_controller.controller import FOLLOW
    assert FOLLOW == 0
    with pytest.warns(DeprecationWarning, match='controllers.params.ControllerParams'):
        from mona_controller.controller import ControllerParams as Old
    assert Old is ControllerParams
    with pytest.warns(DeprecationWarning, match='controllers.network_weights.genome_size'):
        from mona_controller.network import genome_size  # noqa: F401
    with pytest.raises(ImportError, match='nothing'):
        from mona_controller.reference import nothing  # noqa: F401
