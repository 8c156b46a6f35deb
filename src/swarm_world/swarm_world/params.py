"""Parameters of the simulated world (arena, cue, stepping, cleaning)."""

from __future__ import annotations

import dataclasses
from typing import Any

from mona_controller.schema import ParameterError, param, validate
from swarm_world.arena import NAME_PATTERN, Arena, parse_obstacles
from swarm_world.layouts import layout_obstacles
from swarm_world.sources import PAPER_SOURCE, PROFILES, Source

CLEANING_MODES = ('monotone', 'literal', 'blend')
#: What the initial cue is under an obstacle: the sources' profile, or none.
OBSTACLE_CUE = ('keep', 'clear')


@dataclasses.dataclass(frozen=True)
class WorldParams:
    """The arena, the cue field and how the world steps and cleans (docs/model.md)."""

    arena_side: float = param(2.85, unit='m', low=0.2, high=100.0,
                              doc='side of the square walled arena')
    cell_size: float = param(0.01, unit='m', low=0.001, high=0.5,
                             doc='side of one cue raster cell')
    cue_diameter: float = param(2.227, unit='m', low=0.0, high=200.0,
                                doc='diameter of the contaminated disc, centred in the arena')
    cue_peak: float = param(255.0, unit='cue units', low=0.0, high=255.0,
                            doc='cue intensity at the disc centre, falling linearly to 0')
    step_period: float = param(0.032, unit='s', low=0.001, high=1.0,
                               doc='simulated time per step (physics, sensing)')
    control_steps: int = param(1, unit='steps', low=1, high=1000,
                               doc='world steps per control step: the controllers answer every '
                                   'k-th step and the wheels hold their command in between '
                                   '(the control period is k x step_period)')
    cleaning: str = param('monotone', choices=CLEANING_MODES,
                          doc="eq. 3 as 'monotone' (each cell loses the amount), "
                              "'literal' (cell = mean reading - amount, the paper's text) or "
                              "'blend' (as a Webots Display draws black with opacity "
                              'amount / 255: 8-bit cells lose floor(amount) x value / 255)')
    cleaning_period: float = param(1.0, unit='s', low=0.001, high=3600.0,
                                   doc='how often a waiting robot cleans its patch')
    cleaning_radius: int = param(4, unit='cells', low=0, high=100,
                                 doc='half-size of the square cleaning patch (4: 9 x 9 cells)')
    cleaning_peak: float = param(8.0, unit='cue units', low=0.0, high=255.0,
                                 doc='amount removed at the patch centre; offset (p, q) '
                                     'loses peak - sqrt(p^2 + q^2)')
    cleaning_quorum: int = param(1, unit='robots', low=1, high=1000,
                                 doc='k: a cleaning robot cleans at a tick only with at least '
                                     'k - 1 other cleaning robots within cleaning_range (a '
                                     "task needing several robots); 1: the paper's eq. 3, "
                                     'every cleaning robot cleans')
    cleaning_range: float = param(0.2, unit='m', low=0.0, high=100.0,
                                  doc='r: how close (centre to centre) the other robots of a '
                                      'cleaning group must be (read only when '
                                      'cleaning_quorum > 1)')
    collision_slop: float = param(0.0005, unit='m', low=0.0, high=0.01,
                                  doc='allowed overlap of colliding bodies in pymunk')
    # Beyond the paper (docs/model.md "Leaks beyond the paper"); every default is the paper.
    sources: tuple[Any, ...] = param((), keyed=True,
                           doc='leak sources, name -> [x m, y m, radius m, peak cue units]; '
                               "none: the paper's one disc ('source': the arena centre, "
                               'cue_diameter, cue_peak)')
    source_profile: tuple[Any, ...] = param((), keyed=True,
                                  doc="name -> ['linear'] or ['gaussian'] (default linear; "
                                      'gaussian: sigma = radius / 3, 0 beyond the radius)')
    source_emission: tuple[Any, ...] = param((), keyed=True,
                                   doc='name -> [cue units/s]: a leaking source restores its '
                                       'profile at this rate (at its peak), never above it')
    source_velocity: tuple[Any, ...] = param((), keyed=True,
                                   doc='name -> [vx m/s, vy m/s]: moves at constant velocity, '
                                       'reflecting at the walls')
    source_path: tuple[Any, ...] = param((), keyed=True,
                               doc='name -> [speed m/s, x1, y1, x2, y2, ...]: moves along the '
                                   'closed loop from its position through these waypoints (m)')
    cue_file: str = param('', doc="initial cue from a .npy array (cue units, row = y) or an "
                                  "image (grey level, top = +y), scaled to the arena; a path "
                                  "absolute or relative to the parameter file naming it; '' "
                                  "= the sources' profiles")
    diffusion: float = param(0.0, unit='m^2/s', low=0.0, high=1.0,
                             doc='diffusion coefficient of the cue (0: none)')
    half_life: float = param(0.0, unit='s', low=0.0, high=1e9,
                             doc='evaporation half-life of the cue (0: does not evaporate)')
    transport_period: float = param(1.0, unit='s', low=0.001, high=3600.0,
                                    doc='how often diffusion, evaporation and emission update '
                                        'the cue (sim time)')
    obstacles: tuple[Any, ...] = param((), keyed=True,
                             doc='static obstacles, name -> [disc, x, y, radius], [rect, x0, '
                                 'y0, x1, y1] or [polygon, x1, y1, x2, y2, x3, y3, ...] (m; '
                                 'a convex polygon; the kind may be left out: docs/model.md '
                                 '"Obstacles"); none: the bare square')
    obstacle_cue: str = param('keep', choices=OBSTACLE_CUE,
                              doc="the initial cue under an obstacle: 'keep' it (robots "
                                  "cannot reach it to clean it) or 'clear' it (0 in every "
                                  "cell whose centre an obstacle covers)")
    layout: str = param('', doc="a registered obstacle layout (a plug-in's: "
                               'docs/extending.md, "An obstacle layout"), whose obstacles '
                               "join world.obstacles; '' = none")

    def __post_init__(self) -> None:
        validate(self, 'world.')
        self.source_list()  # names, lengths and places checked at start-up
        self.arena()  # the obstacles too
        if not (self.sources or self.cue_file) and self.cue_diameter > self.arena_side * 1.4143:
            raise ParameterError(f'world.cue_diameter = {self.cue_diameter} exceeds the arena '
                                 f'diagonal ({self.arena_side} m side)')
        if round(self.arena_side / self.cell_size) < 2:
            raise ParameterError(f'world.cell_size = {self.cell_size} leaves fewer than 2 cells '
                                 f'across the arena')

    def source_list(self) -> list[Source]:
        """The leak sources in name order (a ROS parameter server sorts them too), the
        paper's disc when ``sources`` is empty.

        Raises:
            ParameterError: a bad name, a wrong number of values, a source outside the arena,
                or an option naming a source that does not exist.
        """
        given = dict(self.sources) or {PAPER_SOURCE: (*self.centre, self.cue_diameter / 2,
                                                      self.cue_peak)}
        options = {key: dict(getattr(self, key)) for key in
                   ('source_profile', 'source_emission', 'source_velocity', 'source_path')}
        for key, mapping in options.items():
            for name in mapping:
                if name not in given:
                    raise ParameterError(f'world.{key}.{name}: no source named {name!r} '
                                         f'(sources: {", ".join(given)})')
        result = []
        for name, values in sorted(given.items()):
            where = f'world.sources.{name}'
            if not NAME_PATTERN.match(name):
                raise ParameterError(f'{where}: a source name must be a lower-case identifier')
            if name == PAPER_SOURCE and len(given) > 1:  # its columns would be the totals'
                raise ParameterError(f"{where}: {PAPER_SOURCE!r} names the paper's one source; "
                                     'give several sources other names')
            x, y, radius, peak = _numbers(where, values, 4)
            if not (0 <= x <= self.arena_side and 0 <= y <= self.arena_side):
                raise ParameterError(f'{where}: position ({x}, {y}) is outside the '
                                     f'{self.arena_side} m arena')
            if radius < 0 or not 0 <= peak <= 255:
                raise ParameterError(f'{where}: radius must be >= 0 m and peak in 0..255 '
                                     f'cue units (got {radius}, {peak})')
            profile = options['source_profile'].get(name, ('linear',))
            if len(profile) != 1 or profile[0] not in PROFILES:
                raise ParameterError(f'world.source_profile.{name} = {list(profile)}: expected '
                                     f'[{" | ".join(PROFILES)}]')
            (emission,) = _numbers(f'world.source_emission.{name}',
                                   options['source_emission'].get(name, (0.0,)), 1)
            velocity = _numbers(f'world.source_velocity.{name}',
                                options['source_velocity'].get(name, (0.0, 0.0)), 2)
            path = _numbers(f'world.source_path.{name}',
                            options['source_path'].get(name, (0.0,)), None)
            if emission < 0 or path[0] < 0 or len(path) % 2 == 0:
                raise ParameterError(f'{where}: emission and path speed must be >= 0 and a '
                                     'path is [speed, x1, y1, ...]')
            if name in options['source_velocity'] and name in options['source_path']:
                raise ParameterError(f'{where}: give it a velocity or a path, not both')
            points = tuple(zip(path[1::2], path[2::2]))
            if any(not (0 <= px <= self.arena_side and 0 <= py <= self.arena_side)
                   for px, py in points):
                raise ParameterError(f'world.source_path.{name}: a waypoint lies outside the '
                                     f'{self.arena_side} m arena')
            result.append(Source(name, x, y, radius, peak, profile[0], emission,
                                 (velocity[0], velocity[1]), path[0], points))
        return result

    def arena(self) -> Arena:
        """The walled arena and its obstacles (in name order).

        Raises:
            ParameterError: a bad obstacle (see :func:`swarm_world.arena.parse_obstacles`).
        """
        sources = [(source.name, source.x, source.y) for source in self.source_list()]
        obstacles = parse_obstacles(self.obstacles, self.arena_side, sources)
        if self.layout:
            laid = parse_obstacles(layout_obstacles(self.layout, self), self.arena_side,
                                   sources, f'world.layout = {self.layout!r}: obstacle ')
            both = {o.name for o in obstacles} & {o.name for o in laid}
            if both:
                raise ParameterError(f'world.obstacles.{min(both)}: the layout '
                                     f'{self.layout!r} has an obstacle of that name too')
            obstacles = tuple(sorted(obstacles + laid, key=lambda obstacle: obstacle.name))
        return Arena(self.arena_side, obstacles)

    @property
    def paper_field(self) -> bool:
        """Whether the cue is the paper's: one still disc, no file, no transport, none of it
        cleared under obstacles."""
        return not (self.sources or self.source_emission or self.source_velocity
                    or self.source_path or self.source_profile or self.cue_file
                    or self.diffusion or self.half_life
                    or ((self.obstacles or self.layout) and self.obstacle_cue == 'clear'))

    @property
    def step_ns(self) -> int:
        """The step period in integer nanoseconds (sim time is kept in ns, exactly)."""
        return round(self.step_period * 1e9)

    @property
    def cells(self) -> int:
        """Cells along one side of the cue raster."""
        return round(self.arena_side / self.cell_size)

    @property
    def centre(self) -> tuple[float, float]:
        """The arena centre, which is the cue (and source) centre (m)."""
        return (self.arena_side / 2, self.arena_side / 2)


def _numbers(where: str, values: tuple[Any, ...], count: int | None) -> tuple[float, ...]:
    """``values`` as floats, ``count`` of them (any number if None)."""
    if (count is not None and len(values) != count) or any(
            isinstance(v, (bool, str)) for v in values):
        raise ParameterError(f'{where} = {list(values)}: expected {count or "some"} numbers')
    return tuple(float(v) for v in values)


@dataclasses.dataclass(frozen=True)
class WorldNodeParams:
    """Options of the world node (how it steps and publishes; not part of the model)."""

    mode: str = param('lockstep', choices=('lockstep', 'realtime'),
                      doc='lockstep: wait for every command; realtime: step on the wall clock')
    lockstep_deadline: float = param(2.0, unit='s (wall)', low=0.001, high=3600.0,
                                     doc='how long a lockstep round waits for the commands')
    real_time_factor: float = param(0.0, unit='sim s per wall s', low=0.0, high=1e6,
                                    doc='lockstep: step no faster than this (1.0: at most real '
                                        'time, to watch a run live); 0: as fast as every '
                                        'robot answers')
    absent_after: int = param(3, unit='steps', low=1, high=1_000_000,
                              doc='consecutive misses after which a robot is absent and no '
                                  'longer waited for (it rejoins when it answers)')
    recorders: str = param('', doc="comma-separated node names of the recorders (the metrics "
                                   "node: 'metrics') that must say they record an episode "
                                   "before its step 0 ('' = none)")
    recorder_lag: float = param(10.0, unit='s (sim)', low=0.0, high=1e7,
                                doc='lockstep: never step more than this ahead of the slowest '
                                    "recorder's whole record (0 = do not wait for recorders "
                                    'while running; else at least metrics.sample_period)')
    recorder_timeout: float = param(60.0, unit='s (wall)', low=0.1, high=86400.0,
                                    doc='how long an episode waits for a recorder to record its '
                                        'start, or one that fell behind, before it fails')
    start_timeout: float = param(60.0, unit='s (wall)', low=0.1, high=86400.0,
                                 doc='how long to wait for every controller and recorder to '
                                     'connect')
    clock_period: float = param(0.1, unit='s (sim)', low=0.0, high=3600.0,
                                doc='/clock publishing period (0: every step)')
    map_period: float = param(1.0, unit='s (sim)', low=0.0, high=1e7,
                              doc='cue map, grid and markers publishing period (0: every step)')
    status_period: float = param(1.0, unit='s (sim)', low=0.0, high=1e7,
                                 doc='/world/status period while running (0: every step)')
    output_dir: str = param('', doc="directory for episode_<k>/world_final.npz ('' = none)")

    def __post_init__(self) -> None:
        validate(self)
