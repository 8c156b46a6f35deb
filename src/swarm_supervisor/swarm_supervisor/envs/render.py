"""What the environments' ``render()`` draws (``render_mode='rgb_array'``): the frame of the
episode's video (:class:`swarm_supervisor.media.video.Renderer`) for its current state, as
an [H, W, 3] uint8 array: the cue map being cleaned, the obstacles, the robots (red while
their cleaner is on, grey otherwise: an agent's action has no controller state), the clock.

Gymnasium's ``Env.render`` and PettingZoo's ``ParallelEnv.render`` ask for this array in
'rgb_array' mode, the mode named in ``metadata['render_modes']`` and chosen when the
environment is made; without a mode, ``render()`` draws nothing and warns, as theirs do.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import logger

from mona_controller.controllers.beeclust import WAIT
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import Episode
from swarm_supervisor.envs.spaces import EnvError

#: The modes ``render()`` supports (the environments' ``metadata['render_modes']``).
RENDER_MODES = ['rgb_array']
#: The frame's width in pixels (its height is 9/16 of it).
WIDTH = 640


def check_render_mode(render_mode: str | None) -> str | None:
    """``render_mode`` if supported (None: no rendering).

    Raises:
        EnvError: another mode, naming the supported ones.
    """
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise EnvError(f'render_mode = {render_mode!r} is not supported: one of '
                       f'{", ".join(map(repr, RENDER_MODES))}, or None')
    return render_mode


class FrameDrawer:
    """Draws frames of episodes of one config (the static parts, the title with the seed
    among them, are laid out once per episode seed). The metric plots stay empty: the
    environment's ``metrics`` hold the rows so far."""

    def __init__(self, config: SwarmConfig, width: int = WIDTH) -> None:
        self.config = config
        self.width = width
        self.seed: int | None = None
        self.renderer: Any = None

    def _layout(self, seed: int) -> None:
        from mona_controller.controllers import states_of
        from swarm_metrics.bags.analysis import EpisodeSetup
        from swarm_supervisor.media.recorded import Record
        from swarm_supervisor.media.video import Renderer

        config = self.config
        population = config.episode.population
        setup = EpisodeSetup(episode=0, seed=seed, population=population,
                             duration=config.episode.duration, start_ns=0,
                             initial_poses=np.zeros((population, 3)), world=config.world,
                             mona=config.mona, sensing=config.sensing,
                             metrics=config.metrics, parameters=config.to_dict(),
                             states=states_of(config.controller.kind))
        record = Record(setup=setup, runner='environment', pose_times=np.zeros(1, np.int64),
                        poses=np.zeros((1, population, 3)), states=None, cleaning=[],
                        cue_maps=[], metrics={}, obstacles=config.world.arena().obstacles)
        self.renderer = Renderer(record, self.width)
        self.seed = seed

    def frame(self, episode: Episode, cleaning: np.ndarray) -> np.ndarray:
        """The frame of ``episode`` now; ``cleaning``: [N] bool, whose cleaner is on."""
        from swarm_supervisor.media.video import MOVING_COLOUR

        if episode.seed != self.seed:
            self._layout(episode.seed)
        renderer = self.renderer
        moving = (np.array(MOVING_COLOUR[:3]) * 255).astype(np.uint8)
        colours = np.where(np.asarray(cleaning, dtype=bool)[:, None],
                           renderer.colours[WAIT], moving)
        return renderer.compose(episode.world.field.cue, episode.world.poses, colours,
                                episode.time_ns)


def no_mode_warning() -> None:
    """What ``render()`` says without a render mode (Gymnasium's and PettingZoo's words)."""
    logger.warn('You are calling render method without specifying any render mode: make the '
                "environment with render_mode='rgb_array'.")
