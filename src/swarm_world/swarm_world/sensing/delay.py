"""The command latency (``sensing.command_latency``): a delay line between the controllers'
commands and the wheels, as plain Python (no ROS).

A real Mona gets its commands over a radio link that takes time; the simulation can give the
same delay so that simulated and real runs compare at the real link's timing (docs/model.md,
"The real link"). The line holds ``steps`` world steps of commands per robot: what goes in at
step s drives step s + ``steps``; before the first command is out, a robot stands still with
its cleaner off (the firmware stops the wheels until its first command, docs/link.md). Both
runners apply it inside :meth:`swarm_world.world.World.step` (the batched engine per world),
so the embedded runner, a batch and the world node delay alike.
"""

from __future__ import annotations

import numpy as np


class CommandDelay:
    """A fixed delay of ``steps`` world steps for the commands of ``population`` robots.

    Args:
        steps: the delay in world steps (``command_latency x control_steps``), at least 1.
        population: the robots of the episode.
    """

    def __init__(self, steps: int, population: int) -> None:
        if steps < 1:
            msg = f'a command delay of {steps} steps: use no delay line for 0'
            raise ValueError(msg)
        self.steps = steps
        self._linear = np.zeros((steps, population))
        self._angular = np.zeros((steps, population))
        self._cleaner = np.zeros((steps, population), dtype=bool)
        self._count = 0  # steps taken: the slot of step s is s % steps

    def shift(self, linear: np.ndarray, angular: np.ndarray,
              cleaner: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Put this step's commands in; return the ones that reach the wheels now (those put
        in ``steps`` steps ago, or a stop). Call once per world step."""
        slot = self._count % self.steps
        out = (self._linear[slot].copy(), self._angular[slot].copy(),
               self._cleaner[slot].copy())
        self._linear[slot] = linear
        self._angular[slot] = angular
        self._cleaner[slot] = cleaner
        self._count += 1
        return out
