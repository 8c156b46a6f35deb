"""What an agent sees and does, as arrays: observations from a Mona's readings, wheel and
cleaner commands from actions, and the shared reward. Pure numpy (the environments wrap it).

An agent (one Mona) observes, float64, in this order:

- ``ground``: its left and right ground readings / 255 (0 clean .. 1 the cue's peak);
- ``proximity``: per IR beam, 1 - range / ``mona.ir_range`` (0 nothing within range .. 1
  touching), beams in ``mona.ir_count`` order from the left;
- ``robot``: per IR beam, 1 when what the beam sees is a robot (after the encounter model),
  else 0.

An agent acts with three numbers: its left and right wheel commands in wheel units
(``mona.wheel_unit_speed`` m/s each; clipped to +-``mona.max_wheel_command``) and its
cleaner (on when >= 0.5: it cleans eq. 3's patch once per ``world.cleaning_period``).
"""

from __future__ import annotations

import numpy as np

from mona_controller.controllers import Command
from mona_controller.mona import MonaParams

#: left wheel, right wheel, cleaner
ACTION_SIZE = 3


class EnvError(ValueError):
    """An action or a configuration the environment cannot take."""


def observation_size(mona: MonaParams) -> int:
    """Numbers per agent: 2 ground readings, then a proximity and a robot flag per beam."""
    return 2 + 2 * mona.ir_count


def observations(ground: np.ndarray, ranges: np.ndarray, is_robot: np.ndarray,
                 mona: MonaParams) -> np.ndarray:
    """[N, observation_size] float64 from the readings of N robots (ground [N, 2] uint8,
    ranges [N, K] float32 in m with inf for nothing, is_robot [N, K] bool)."""
    near = 1.0 - ranges.astype(np.float64) / mona.ir_range
    near = np.where(np.isfinite(near), np.clip(near, 0.0, 1.0), 0.0)
    return np.concatenate([ground.astype(np.float64) / 255.0, near,
                           is_robot.astype(np.float64)], axis=1)


def commands_from_actions(actions: np.ndarray, mona: MonaParams) -> Command:
    """The wheel and cleaner commands of [N, 3] actions (see the module docstring).

    Raises:
        EnvError: the actions are not [N, 3] finite numbers.
    """
    actions = np.asarray(actions, dtype=np.float64)
    if actions.ndim != 2 or actions.shape[1] != ACTION_SIZE:
        raise EnvError(f'actions must be [N, {ACTION_SIZE}] (left, right, cleaner); got shape '
                       f'{actions.shape}')
    if not np.isfinite(actions).all():
        raise EnvError('actions must be finite numbers')
    top = mona.max_wheel_command
    wheels = np.clip(actions[:, :2], -top, top)
    return Command(np.ascontiguousarray(wheels), actions[:, 2] >= 0.5)


def reward(before: float, after: float, initial: float) -> float:
    """The swarm's shared reward for a step: the cue it removed, as a share of the initial
    cue (mean cue before and after the step, and at t = 0); 0 on a clean start."""
    return (before - after) / initial if initial > 0 else 0.0
