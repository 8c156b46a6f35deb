"""The cue field of one episode: its initial raster, its sources, and everything that changes it.

Robots clean it (eq. 3, on each cleaning tick); between those it diffuses, evaporates and is
re-emitted by leaking sources on transport ticks of its own period (``world.transport_period``).
Tick k happens at the first step at or after k periods and advances the field by exactly one
period, with the sources where they are at k periods; within one step the robots clean first.
The world runs this class, and every replica of the cue (the metrics node, bag analysis,
videos) replays the cleaning record through it, so every copy of an episode's cue is equal
bit for bit. Pure (no ROS).
"""

from __future__ import annotations

import numpy as np

from mona_controller.mona import MonaParams
from swarm_world import cue as cue_field
from swarm_world import transport
from swarm_world.params import WorldParams
from swarm_world.sensing.ground import ground_readings
from swarm_world.sensing.params import SensingParams
from swarm_world.sources import Source, load_cue_file


def initial_cue(params: WorldParams) -> np.ndarray:
    """The cue at t = 0: the file's map if ``world.cue_file`` is set, else the highest of the
    sources' profiles at each cell (the paper's disc by default), float32 cue units; with
    ``world.obstacle_cue: clear``, 0 in every cell whose centre an obstacle covers."""
    if params.cue_file:
        cue = load_cue_file(params.cue_file, params.cells)
    else:
        deposits = [source.deposit(params.cells, params.cell_size, 0.0, params.arena_side)
                    for source in params.source_list()]
        cue = np.maximum.reduce(deposits).astype(np.float32)
    if params.obstacle_cue == 'clear' and (params.obstacles or params.layout):
        cue[params.arena().under(params.cells, params.cell_size)] = 0.0
    return cue


class CueField:
    """The evolving cue raster (float32 [rows, cols], row = y cell) of one episode."""

    def __init__(self, params: WorldParams, mona: MonaParams, sensing: SensingParams) -> None:
        self.params = params
        self.mona = mona
        self.sensing = sensing
        self.sources: list[Source] = params.source_list()
        self.initial = initial_cue(params)
        self.initial.setflags(write=False)
        self.initial_mean = float(self.initial.mean(dtype=np.float64))
        self.kernel = cue_field.cleaning_kernel(params.cleaning_radius, params.cleaning_peak)
        self.period_ns = round(params.transport_period * 1e9)
        self.step_ns = params.step_ns
        #: Whether anything but cleaning changes the cue (else ticks are skipped).
        self.dynamic = bool(params.diffusion or params.half_life
                            or any(source.emission for source in self.sources))
        self.cue = self.initial.copy()
        self.time_ns = 0  #: the episode time the transport ticks have reached

    def reset(self) -> None:
        """Back to the initial cue at t = 0."""
        self.cue = self.initial.copy()
        self.time_ns = 0

    @property
    def names(self) -> tuple[str, ...]:
        """The sources' names, in order."""
        return tuple(source.name for source in self.sources)

    def source_positions(self, t: float) -> np.ndarray:
        """[S, 2] where the sources are at sim time ``t`` (s)."""
        return np.array([source.position(t, self.params.arena_side)
                         for source in self.sources], dtype=np.float64).reshape(-1, 2)

    def clean_at(self, time_ns: int, poses: np.ndarray) -> None:
        """The cleaning tick of the step that ends at episode time ``time_ns``: the transport
        ticks of the steps before it (within a step the robots clean first), then eq. 3 under
        each robot at ``poses`` [M, 3], in order. The world and every replay of a cleaning
        record call this, so they apply the same changes in the same order."""
        self.advance_to(time_ns - self.step_ns)
        clean_under(self.cue, poses, self.params, self.mona, self.sensing, self.kernel)

    def advance_to(self, time_ns: int) -> bool:
        """Run every transport tick due by episode time ``time_ns``; True if the cue changed.

        Never goes back: a time before the one reached does nothing.
        """
        first = self.time_ns // self.period_ns + 1
        last = time_ns // self.period_ns
        self.time_ns = max(self.time_ns, time_ns)
        if not self.dynamic or last < first:
            return False
        for k in range(first, last + 1):
            self.tick(k)
        return True

    def tick(self, k: int) -> None:
        """Transport tick ``k``: diffuse and evaporate for one period, then let each leaking
        source restore its profile where it is at k periods."""
        params, dt = self.params, self.params.transport_period
        cue = transport.diffuse(self.cue, params.diffusion, dt, params.cell_size)
        factor = transport.evaporation_factor(params.half_life, dt)
        if factor != 1.0:
            cue = (cue * factor).astype(np.float32)
        t = k * dt
        for source in self.sources:
            if source.emission:
                window, profile = source.window(params.cells, params.cell_size, t,
                                                 params.arena_side)
                transport.emit(cue[window], profile, source.emission, source.peak, dt)
        self.cue = cue


def clean_under(cue: np.ndarray, poses: np.ndarray, params: WorldParams, mona: MonaParams,
                sensing: SensingParams, kernel: np.ndarray) -> None:
    """One cleaning tick, in place: eq. 3 under each robot at ``poses`` [M, 3], in order.

    In literal mode a robot's level is its mean ground reading (without sensor noise).
    """
    if not len(poses):
        return
    cells = cue_field.cell_index(poses[:, :2], params.cell_size, params.cells)
    levels = None
    if params.cleaning == 'literal':
        sensed = cue_field.sensed_field(
            cue, cue_field.footprint_cells(sensing.ground_footprint, params.cell_size))
        ground = ground_readings(sensed, params.cell_size, poses, mona, sensing)
        levels = ground.astype(np.float64).mean(axis=1)
    cue_field.clean(cue, cells, kernel, literal_levels=levels,
                    blend=params.cleaning == 'blend')
