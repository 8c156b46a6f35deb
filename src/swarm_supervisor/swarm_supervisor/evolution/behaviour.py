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
  a robot (BEECLUST waits only after meeting one; a solitary cleaner needs none).
"""

from __future__ import annotations

import numpy as np

from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import Episode


def behaviour(config: SwarmConfig) -> dict[str, float]:
    """The measures above over one whole episode of ``config``."""
    episode = Episode(config)
    world, mona = episode.world, config.mona
    steps = cleaning = standing = beside = 0
    forward = moving = 0.0
    while not episode.done:
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
    robot_steps = steps * config.episode.population
    return {'cleaner_on': cleaning / robot_steps,
            'forward_speed': forward / robot_steps,
            'moving_speed': moving / max(robot_steps - standing, 1),
            'standing': standing / robot_steps,
            'cleaning_beside_robot': beside / max(cleaning, 1)}
