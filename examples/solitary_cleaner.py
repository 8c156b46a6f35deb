"""A controller of your own: the solitary cleaner, a baseline BEECLUST is measured against.

It follows the gradient as BEECLUST does (eq. 2), but it cleans alone: a robot whose mean
reading S reaches :data:`CLEAN_ABOVE` stops and cleans for eq. 1's wait w(S), whether or not
another robot is there, then drives on for :data:`COOLDOWN` seconds before it may stop
again. Anything its beams see (a wall or a robot) it turns away from in place. No random
numbers: every robot's behaviour follows from its readings and its clock alone.

Run it (docs/extending.md, "A controller")::

    .venv/bin/python examples/solitary_cleaner.py          # 30 robots, 300 s, both kinds

``register()`` adds the kind ``solitary`` to this process. To run it in a study's worker
processes or as a controller node, declare the entry point instead, in your package's
setup.py: ``entry_points={'mona_swarm.controllers': ['solitary = examples.solitary_cleaner:
SolitaryCleaner']}``.
"""

from __future__ import annotations

import numpy as np

from mona_controller.controller import FOLLOW, TURN, WAIT, gradient_wheels, waiting_time
from mona_controller.controllers import Command, Controller, register_controller

#: The mean reading at which a robot stops to clean (cue units).
CLEAN_ABOVE = 100.0
#: Seconds a robot drives on after cleaning before it may stop again.
COOLDOWN = 10.0


class SolitaryCleaner(Controller):
    """Follow the gradient; clean alone where the cue is strong; turn away from anything."""

    #: The per-robot arrays ``merge`` joins: the base class's, and when the current wait or
    #: cool-down ends.
    PER_ROBOT = (*Controller.PER_ROBOT, 'until')

    def __init__(self, params, mona, robot_ids) -> None:
        super().__init__(params, mona, robot_ids)
        self.until = np.zeros(len(self.robot_ids))

    def derive(self) -> None:
        """Per robot, from its parameter set: eq. 2's beta and gain, the wheels' limit, and
        the in-place turn's command."""
        params = [self.params[i] for i in self.param_index]
        mona = [self.mona[i] for i in self.param_index]
        self.beta = np.array([p.speed / m.wheel_unit_speed for p, m in zip(params, mona)])
        self.alpha = np.array([p.alpha for p in params])
        self.top = np.array([[m.max_wheel_command] for m in mona])
        self.spin = np.array([min(p.turn_speed / m.wheel_unit_speed, m.max_wheel_command)
                              for p, m in zip(params, mona)])
        self.sets = params  # each robot's own parameter set, for eq. 1

    def reset(self, seed: int) -> None:
        self.state[:] = FOLLOW
        self.until[:] = 0.0
        self.encounters[:] = 0

    def step(self, ground, ranges, is_robot, now) -> Command:
        now = np.broadcast_to(np.asarray(now, dtype=np.float64), self.until.shape)
        waiting = self.state == WAIT
        # A wait that is over: drive on, and do not stop again before the cool-down ends.
        done = waiting & (now >= self.until)
        self.state[done] = FOLLOW
        self.until[done] = now[done] + COOLDOWN
        level = ground.astype(np.float64).mean(axis=1)
        start = (self.state == FOLLOW) & (now >= self.until) & (level >= CLEAN_ABOVE)
        for i in np.flatnonzero(start):  # few robots a step: eq. 1 with each one's own set
            self.until[i] = now[i] + waiting_time(level[i], self.sets[i])
            self.state[i] = WAIT
        seen = (ranges < np.inf).any(axis=1) & (self.state != WAIT)
        self.state[seen] = TURN
        self.state[~seen & (self.state == TURN)] = FOLLOW
        wheels = gradient_wheels(ground, self.beta, self.alpha, self.top)
        wheels[self.state == WAIT] = 0.0
        turning = self.state == TURN
        wheels[turning, 0], wheels[turning, 1] = -self.spin[turning], self.spin[turning]
        return Command(wheels, self.state == WAIT)


def register() -> None:
    """Add the kind ``solitary`` (this process, and those it forks)."""
    register_controller('solitary', f'{__name__}:SolitaryCleaner')


def main() -> None:
    """Both kinds on the same 300 s, 30 robots: how much cue each leaves."""
    from swarm_supervisor.config import load_config
    from swarm_supervisor.engine import run_episode

    register()
    base = load_config().replace(episode={'population': 30, 'duration': 300.0, 'seed': 1})
    for kind in ('beeclust', 'solitary'):
        result = run_episode(base.replace(controller={'kind': kind}))
        print(f'{kind}: {result.metrics[-1]["mean_cue_fraction"]:.1%} of the cue left after '
              f'300 s, {int((result.metrics[-1]["ratio_near_source"]) * 30)} robots near the '
              'source')


if __name__ == '__main__':
    main()
