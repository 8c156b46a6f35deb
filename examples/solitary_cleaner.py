"""A controller of your own: the solitary cleaner, a baseline BEECLUST is measured against.

One module: a kind with two parameters of its own (``controller.solitary.clean_above`` and
``controller.solitary.cooldown``) and three states of its own (roam, clean, dodge), plus one
line that registers it (:func:`register`). It follows the gradient as BEECLUST does (eq. 2,
with BEECLUST's gain), but it cleans alone: a robot whose mean reading S reaches
``clean_above`` stops and cleans for eq. 1's wait w(S) (BEECLUST's wait parameters), whether
or not another robot is there, then drives on for ``cooldown`` seconds before it may stop
again. Anything its beams see (a wall or a robot) it turns away from in place. No random
numbers: every robot's behaviour follows from its readings and its clock alone.

Run it (docs/extending.md, "A controller")::

    .venv/bin/python examples/solitary_cleaner.py          # 30 robots, 300 s, both kinds

``register()`` adds the kind ``solitary`` to this process. To run it in a study's worker
processes or as a controller node, declare the entry point instead, in your package's
setup.py: ``entry_points={'mona_swarm.controllers': ['solitary = examples.solitary_cleaner:
SolitaryCleaner']}``. Its parameters then sit in the parameter file as
``controller: {kind: solitary, solitary: {clean_above: 80.0}}``, and markers, videos and the
Foxglove layout show its robots as roam (green), clean (red) and dodge (blue).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mona_controller.controllers import Command, Controller, State, register_controller
from mona_controller.controllers.beeclust import BeeclustParams, gradient_wheels, waiting_time
from mona_controller.schema import param, validate

#: The states, by code.
ROAM, CLEAN, DODGE = 0, 1, 2


@dataclasses.dataclass(frozen=True)
class SolitaryParams:
    """The solitary cleaner's own parameters, controller.solitary.*."""

    clean_above: float = param(100.0, unit='cue units', low=0.0, high=255.0,
                               doc='the mean reading at which a robot stops to clean')
    cooldown: float = param(10.0, unit='s', low=0.0, high=3600.0,
                            doc='how long a robot drives on after cleaning before it may '
                                'stop again')

    def __post_init__(self) -> None:
        validate(self, 'controller.solitary.')


class SolitaryCleaner(Controller):
    """Follow the gradient; clean alone where the cue is strong; turn away from anything."""

    Params = SolitaryParams
    STATES = (State('roam', (0.20, 0.75, 0.25, 1.0)), State('clean', (0.90, 0.10, 0.10, 1.0)),
              State('dodge', (0.25, 0.45, 1.00, 1.0)))
    #: The per-robot arrays ``merge`` joins: the base class's, and when the current wait or
    #: cool-down ends.
    PER_ROBOT = (*Controller.PER_ROBOT, 'until')

    def __init__(self, params, mona, robot_ids) -> None:
        super().__init__(params, mona, robot_ids)
        self.until = np.zeros(len(self.robot_ids))

    def derive(self) -> None:
        """Per robot, from its parameter set: its own section, BEECLUST's (eq. 1 and 2), eq.
        2's beta, the wheels' limit and the in-place turn's command."""
        sets = [(self.params[i], self.mona[i]) for i in self.param_index]
        self.own = [params.section(SolitaryParams) for params, _ in sets]
        self.eqs = [params.section(BeeclustParams) for params, _ in sets]
        self.beta = np.array([p.speed / m.wheel_unit_speed for p, m in sets])
        self.alpha = np.array([eq.alpha for eq in self.eqs])
        self.clean_above = np.array([own.clean_above for own in self.own])
        self.cooldown = np.array([own.cooldown for own in self.own])
        self.top = np.array([[m.max_wheel_command] for _, m in sets])
        self.spin = np.array([min(eq.turn_speed / m.wheel_unit_speed, m.max_wheel_command)
                              for eq, (_, m) in zip(self.eqs, sets)])

    def reset(self, seed: int) -> None:
        self.state[:] = ROAM
        self.until[:] = 0.0
        self.encounters[:] = 0

    def step(self, ground, ranges, is_robot, now) -> Command:
        now = np.broadcast_to(np.asarray(now, dtype=np.float64), self.until.shape)
        # A wait that is over: drive on, and do not stop again before the cool-down ends.
        done = (self.state == CLEAN) & (now >= self.until)
        self.state[done] = ROAM
        self.until[done] = now[done] + self.cooldown[done]
        level = ground.astype(np.float64).mean(axis=1)
        start = (self.state == ROAM) & (now >= self.until) & (level >= self.clean_above)
        for i in np.flatnonzero(start):  # few robots a step: eq. 1 with each one's own set
            self.until[i] = now[i] + waiting_time(level[i], self.eqs[i])
            self.state[i] = CLEAN
        seen = (ranges < np.inf).any(axis=1) & (self.state != CLEAN)
        self.state[seen] = DODGE
        self.state[~seen & (self.state == DODGE)] = ROAM
        wheels = gradient_wheels(ground, self.beta, self.alpha, self.top)
        wheels[self.state == CLEAN] = 0.0
        dodging = self.state == DODGE
        wheels[dodging, 0], wheels[dodging, 1] = -self.spin[dodging], self.spin[dodging]
        return Command(wheels, self.state == CLEAN)


def register() -> None:
    """Add the kind ``solitary`` (this process, and those it forks): the one line."""
    register_controller('solitary', f'{__name__}:SolitaryCleaner')


def main() -> None:
    """Both kinds on the same 300 s, 30 robots: how much cue each leaves, and where the
    robots are at the end, in each kind's own states."""
    from swarm_supervisor.config import load_config
    from swarm_supervisor.engine import Episode

    register()
    base = load_config().replace(episode={'population': 30, 'duration': 300.0, 'seed': 1})
    for kind in ('beeclust', 'solitary'):
        episode = Episode(base.replace(controller={'kind': kind}))
        while not episode.done:
            episode.step()
        states = type(episode.controllers).STATES
        counts = np.bincount(episode.controllers.state, minlength=len(states))
        print(f'{kind}: {episode.metrics()["mean_cue_fraction"]:.1%} of the cue left after '
              '300 s; at the end ' + ', '.join(f'{count} {state.name}'
                                               for state, count in zip(states, counts)))


if __name__ == '__main__':
    main()
