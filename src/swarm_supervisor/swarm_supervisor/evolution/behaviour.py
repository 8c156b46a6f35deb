"""What a controller does in an episode: how often it cleans, how fast it drives, whether it
cleans beside other robots (the post-evaluation's reading of a strategy).

:func:`behaviour` steps one episode as :meth:`~swarm_supervisor.engine.Episode.step` does
(sense, answer, drive), keeping the readings it answered, and sums over robots and steps:

- ``cleaner_on``: the fraction of robot-steps with the cleaner on;
- ``forward_speed``: the mean commanded forward speed, (left + right) / 2 wheels in m/s
  (BEECLUST on a clean floor: ``controller.speed``), and ``moving_speed`` the same over the
  robot-steps that are not standing;
- ``standing``: the fraction of robot-steps with both wheels commanded 0;
- ``cleaning_beside_robot``: of the robot-steps that clean, the fraction whose IR ring sees
  a robot (BEECLUST waits only after meeting one; a solitary cleaner needs none);
- ``removed_per_tick``: the cue its cleaning removed, per robot cleaning at a cleaning tick
  (whose cleaner was on), as a share of what one tick removes from a patch that holds at
  least the amount everywhere (eq. 3's kernel summed): 1 is a full patch, 0 a tick on a
  clean floor or, with ``world.cleaning_quorum`` > 1, a robot with too little company;
- ``distance``: the mean distance a robot travelled over the episode (m).
"""

from __future__ import annotations

import numpy as np

from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import Episode
from swarm_world.field import CueField
from swarm_world.timing import crossed


def behaviour(config: SwarmConfig) -> dict[str, float]:
    """The measures above over one whole episode of ``config``."""
    episode = Episode(config)
    world, mona = episode.world, config.mona
    steps = cleaning = standing = beside = ticking = 0
    forward = moving = distance = 0.0
    removed = _count_removed(world.field)
    tick_ns = round(config.world.cleaning_period * 1e9)
    while not episode.done:
        before, poses = world.time_ns, world.poses.copy()
        if world.steps % episode.control_steps == 0:
            readings = world.sense()
            command = episode.controllers.step(readings.ground, readings.ranges,
                                               readings.is_robot, readings.now)
            episode.command = command
            seen = np.any(readings.is_robot & np.isfinite(readings.ranges), axis=1)
        command = episode.command
        episode.drive(command)
        wheels = command.wheels * mona.wheel_unit_speed
        still = np.all(command.wheels == 0.0, axis=1)
        steps += 1
        cleaning += int(np.sum(command.cleaner))
        standing += int(np.sum(still))
        beside += int(np.sum(command.cleaner & seen))
        forward += float(np.sum(wheels.mean(axis=1)))
        moving += float(np.sum(wheels.mean(axis=1)[~still]))
        distance += float(np.sum(np.hypot(*(world.poses[:, :2] - poses[:, :2]).T)))
        if crossed(before, world.time_ns, tick_ns):
            ticking += int(np.sum(world.cleaning))
    robot_steps = steps * config.episode.population
    patch = float(world.field.kernel.sum(dtype=np.float64))
    return {'cleaner_on': cleaning / robot_steps,
            'forward_speed': forward / robot_steps,
            'moving_speed': moving / max(robot_steps - standing, 1),
            'standing': standing / robot_steps,
            'cleaning_beside_robot': beside / max(cleaning, 1),
            'removed_per_tick': removed[0] / patch / max(ticking, 1),
            'distance': distance / config.episode.population}


def _count_removed(field: CueField) -> list[float]:
    """Make ``field`` add up what its cleaning removes (in a one-item list it returns): each
    tick's transport is run first, then the cue's sum is taken before and after eq. 3."""
    total = [0.0]
    clean_at = field.clean_at

    def counting(time_ns: int, poses: np.ndarray) -> None:
        field.advance_to(time_ns - field.step_ns)  # what clean_at does first
        before = float(field.cue.sum(dtype=np.float64))
        clean_at(time_ns, poses)
        total[0] += before - float(field.cue.sum(dtype=np.float64))

    field.clean_at = counting  # type: ignore[method-assign]
    return total
