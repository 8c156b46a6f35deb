"""Parameters of the simulated world (arena, cue, stepping, cleaning)."""

from __future__ import annotations

import dataclasses

from mona_controller.schema import ParameterError, param, validate

CLEANING_MODES = ('monotone', 'literal')


@dataclasses.dataclass(frozen=True)
class WorldParams:
    """The arena, the cue field and how the world steps and cleans (method.md)."""

    arena_side: float = param(2.85, unit='m', low=0.2, high=100.0,
                              doc='side of the square walled arena')
    cell_size: float = param(0.01, unit='m', low=0.001, high=0.5,
                             doc='side of one cue raster cell')
    cue_diameter: float = param(2.227, unit='m', low=0.0, high=200.0,
                                doc='diameter of the contaminated disc, centred in the arena')
    cue_peak: float = param(255.0, unit='cue units', low=0.0, high=255.0,
                            doc='cue intensity at the disc centre, falling linearly to 0')
    step_period: float = param(0.032, unit='s', low=0.001, high=1.0,
                               doc='simulated time per step (the control period)')
    cleaning: str = param('monotone', choices=CLEANING_MODES,
                          doc="eq. 3 as 'monotone' (each cell loses the amount) or "
                              "'literal' (cell = mean reading - amount, the paper's text)")
    cleaning_period: float = param(1.0, unit='s', low=0.001, high=3600.0,
                                   doc='how often a waiting robot cleans its patch')
    cleaning_radius: int = param(4, unit='cells', low=0, high=100,
                                 doc='half-size of the square cleaning patch (4: 9 x 9 cells)')
    cleaning_peak: float = param(8.0, unit='cue units', low=0.0, high=255.0,
                                 doc='amount removed at the patch centre; offset (p, q) '
                                     'loses peak - sqrt(p^2 + q^2)')
    collision_slop: float = param(0.0005, unit='m', low=0.0, high=0.01,
                                  doc='allowed overlap of colliding bodies in pymunk')

    def __post_init__(self) -> None:
        validate(self, 'world.')
        if self.cue_diameter > self.arena_side * 1.4143:
            raise ParameterError(f'world.cue_diameter = {self.cue_diameter} exceeds the arena '
                                 f'diagonal ({self.arena_side} m side)')
        if round(self.arena_side / self.cell_size) < 2:
            raise ParameterError(f'world.cell_size = {self.cell_size} leaves fewer than 2 cells '
                                 f'across the arena')

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


@dataclasses.dataclass(frozen=True)
class WorldNodeParams:
    """Options of the world node (how it steps and publishes; not part of the model)."""

    mode: str = param('lockstep', choices=('lockstep', 'realtime'),
                      doc='lockstep: wait for every command; realtime: step on the wall clock')
    lockstep_deadline: float = param(2.0, unit='s (wall)', low=0.001, high=3600.0,
                                     doc='how long a lockstep round waits for the commands')
    absent_after: int = param(3, unit='steps', low=1, high=1_000_000,
                              doc='consecutive misses after which a robot is absent and no '
                                  'longer waited for (it rejoins when it answers)')
    recorders: str = param('', doc="comma-separated node names of the recorders (the metrics "
                                   "node: 'metrics') that must say they record an episode "
                                   "before its step 0 ('' = none)")
    recorder_lag: float = param(10.0, unit='s (sim)', low=0.0, high=1e7,
                                doc='lockstep: never step more than this ahead of the slowest '
                                    "recorder's whole record (0 = do not wait for recorders "
                                    'while running)')
    recorder_timeout: float = param(60.0, unit='s (wall)', low=0.1, high=86400.0,
                                    doc='how long a running episode waits for a recorder that '
                                        'fell behind before the episode fails')
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
