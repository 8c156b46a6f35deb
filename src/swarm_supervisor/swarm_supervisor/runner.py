"""The embedded runner: the world and every controller stepped in one process, as fast as the
machine allows. It runs the study, sweeps and tests; the ROS node system runs the same core."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence

import numpy as np

from mona_controller.controller import SwarmController
from mona_controller.mona import wheels_to_twist
from swarm_metrics.metrics import sample
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.placement import place_robots, placement_rng
from swarm_world.world import World


@dataclasses.dataclass
class EpisodeResult:
    """Everything one episode produced."""

    config: SwarmConfig
    metrics: list[dict[str, float]]  #: one row per sample period, from t = 0
    initial_poses: np.ndarray
    final_poses: np.ndarray
    final_cue: np.ndarray
    snapshots: dict[float, tuple[np.ndarray, np.ndarray]]  #: t -> (cue, poses)
    encounters: int  #: robot-robot encounters that started a wait
    steps: int
    wall_time: float  #: seconds

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.steps * self.config.world.step_period / max(self.wall_time, 1e-9)


def start_episode(config: SwarmConfig) -> tuple[World, SwarmController]:
    """Place the robots from the episode seed and reset the world and the controllers."""
    world = World(config.world, config.mona)
    n = config.episode.population
    poses = place_robots(n, config.world.arena_side, config.mona.body_radius,
                         placement_rng(config.episode.seed))
    world.reset(poses)
    controllers = SwarmController(config.controller, config.mona, range(n))
    controllers.reset(config.episode.seed)
    return world, controllers


def run_episode(config: SwarmConfig, *, snapshot_times: Sequence[float] = (),
                progress: Callable[[float], None] | None = None) -> EpisodeResult:
    """Run one episode of ``config.episode`` and collect its metrics.

    Args:
        snapshot_times: sim times (s) at which to keep a copy of the cue map and the poses;
            each is taken at the first metrics sample at or after it.
        progress: called with the sim time after each metrics sample.
    """
    started = time.perf_counter()
    world, controllers = start_episode(config)
    initial_poses = world.poses.copy()
    centre = config.world.centre
    sample_ns = round(config.metrics.sample_period * 1e9)
    pending = sorted(snapshot_times)
    snapshots: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def record(t: float) -> None:
        rows.append(sample(t, world.cue, world.initial_mean_cue, world.poses[:, :2], centre,
                           config.metrics))
        while pending and pending[0] <= t + 1e-9:
            snapshots[pending.pop(0)] = (world.cue.copy(), world.poses.copy())
        if progress is not None:
            progress(t)

    rows: list[dict[str, float]] = []
    record(0.0)
    steps = config.steps()
    for _ in range(steps):
        readings = world.sense()
        command = controllers.step(readings.ground, readings.ranges, readings.is_robot,
                                   readings.now)
        linear, angular = wheels_to_twist(command.wheels, config.mona)
        before = world.time_ns
        world.step(linear, angular, command.cleaner)
        if world.time_ns // sample_ns > before // sample_ns:
            record(world.time_ns // sample_ns * config.metrics.sample_period)
    return EpisodeResult(
        config=config, metrics=rows, initial_poses=initial_poses,
        final_poses=world.poses.copy(), final_cue=world.cue.copy(), snapshots=snapshots,
        encounters=int(controllers.encounters.sum()), steps=steps,
        wall_time=time.perf_counter() - started)
