"""K episodes of the swarm as one Gymnasium ``VectorEnv``, stepped by the batched engine.

Sub-environment k is one episode of N Monas (the same config, seed ``seed + k``); its
observation is [N, obs] and its action [N, 3] (:mod:`swarm_supervisor.envs.spaces`), so a
step takes actions [K, N, 3] and returns observations [K, N, obs], one shared reward per
episode (the cue its swarm removed, as a share of its initial cue), ``terminations`` always
False and ``truncations`` True when the episodes reach ``episode.duration`` (all K together:
they have one length). A step is one control period, as in
:class:`~swarm_supervisor.envs.parallel.MonaSwarmParallelEnv`.

**Autoreset: next step** (Gymnasium's ``AutoresetMode.NEXT_STEP``): the ``step`` after the
one that truncated ignores its actions and starts every episode again from the next seeds
(``seed + K * r + k`` for the r-th round), returning their first observations with reward 0.
:attr:`MonaSwarmVectorEnv.metrics` holds the current round's rows per episode; with
BEECLUST's answers as actions they equal ``run_batch`` (and each lone ``run_episode``) bit
for bit (tests/unit/test_envs.py).
"""

from __future__ import annotations

import numpy as np
from gymnasium.spaces import Box
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from swarm_metrics.metrics import mean_cue
from swarm_supervisor.config import SwarmConfig, load_config
from swarm_supervisor.engine.batch import Batch
from swarm_supervisor.engine.episode import Episode
from swarm_supervisor.envs import render, spaces


class MonaSwarmVectorEnv(VectorEnv):
    """``num_envs`` episodes of one config, stepped together (see the module docstring)."""

    metadata = {'autoreset_mode': AutoresetMode.NEXT_STEP, 'render_modes': render.RENDER_MODES}

    def __init__(self, num_envs: int, config: SwarmConfig | None = None,
                 render_mode: str | None = None) -> None:
        """``config``: each episode (default: the shipped parameter file); ``render_mode``:
        'rgb_array' for :meth:`render`'s frames, None for none."""
        self.render_mode = render.check_render_mode(render_mode)
        if num_envs < 1:
            raise spaces.EnvError(f'num_envs must be at least 1, got {num_envs}')
        self.config = config if config is not None else load_config()
        self.population = self.config.episode.population
        if self.population < 1:
            raise spaces.EnvError('episode.population must be at least 1 for an environment')
        self.num_envs = num_envs
        size, top = spaces.observation_size(self.config.mona), self.config.mona.max_wheel_command
        self.single_observation_space = Box(0.0, 1.0, shape=(self.population, size),
                                            dtype=np.float64)
        low = np.tile([-top, -top, 0.0], (self.population, 1))
        high = np.tile([top, top, 1.0], (self.population, 1))
        self.single_action_space = Box(low, high, dtype=np.float64)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.episodes = [Episode(self.config) for _ in range(num_envs)]
        self.batch: Batch | None = None
        #: Per episode, the metrics rows of the current round (as run_batch's).
        self.metrics: list[list[dict[str, float]]] = [[] for _ in range(num_envs)]
        self._seed = self.config.episode.seed
        self._round = 0
        self._needs_reset = False
        self._initial = np.zeros(num_envs)
        self._mean = np.zeros(num_envs)
        self._cleaning = np.zeros((num_envs, self.population), dtype=bool)
        self._drawer: render.FrameDrawer | None = None

    def reset(self, *, seed: int | None = None,
              options: dict | None = None) -> tuple[np.ndarray, dict]:
        """Start new episodes: with ``seed``, episode k from ``seed + k`` (round 0); without,
        the next round of seeds after the last (``seed + K r + k``, as the autoreset takes
        them; the first round from the config's seed), so every unseeded reset starts fresh
        episodes, as Gymnasium's convention has it, and one seed fixes the whole sequence."""
        if seed is not None:
            self._seed = seed
            self._round = 0
        elif self.batch is not None:
            self._round += 1
        return self._start(), {}

    def _start(self) -> np.ndarray:
        first = self._seed + self.num_envs * self._round
        for k, episode in enumerate(self.episodes):
            episode.reset(first + k)
            self.metrics[k] = [episode.metrics()]
            self._initial[k] = self._mean[k] = mean_cue(episode.world.field.cue)
        self._cleaning[:] = False
        self.batch = Batch(self.episodes)
        self._needs_reset = False
        return self._observe()

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                 np.ndarray, dict]:
        """Drive every robot of every episode with its action for one control period.

        Raises:
            EnvError: not reset yet, or the actions are not [K, N, 3].
        """
        zeros = np.zeros(self.num_envs)
        falses = np.zeros(self.num_envs, dtype=bool)
        if self.batch is None:
            raise spaces.EnvError('call reset() first')
        if self._needs_reset:
            self._round += 1
            return self._start(), zeros, falses, falses.copy(), {}
        actions = np.asarray(actions, dtype=np.float64)
        expected = (self.num_envs, self.population, spaces.ACTION_SIZE)
        if actions.shape != expected:
            raise spaces.EnvError(f'actions must have shape {expected}, got {actions.shape}')
        command = spaces.commands_from_actions(actions.reshape(-1, spaces.ACTION_SIZE),
                                               self.config.mona)
        self._cleaning = command.cleaner.reshape(self.num_envs, self.population)
        for _ in range(self.config.world.control_steps):
            for episode, step in self.batch.drive(command):
                if step.sampled:
                    self.metrics[self.episodes.index(episode)].append(episode.metrics())
            if self.batch.done:
                break
        rewards = np.empty(self.num_envs)
        for k, episode in enumerate(self.episodes):
            now = mean_cue(episode.world.field.cue)
            rewards[k] = spaces.reward(self._mean[k], now, self._initial[k])
            self._mean[k] = now
        over = self.batch.done
        self._needs_reset = over
        return self._observe(), rewards, falses, np.full(self.num_envs, over), {}

    def render(self) -> tuple[np.ndarray, ...] | None:
        """With ``render_mode='rgb_array'``: one frame per episode, as its video draws it
        ([H, W, 3] uint8, :mod:`~swarm_supervisor.envs.render`); without a mode: None, and a
        warning."""
        if self.render_mode is None:
            render.no_mode_warning()
            return None
        if self.batch is None:
            raise spaces.EnvError('call reset() before render()')
        if self._drawer is None:
            self._drawer = render.FrameDrawer(self.config)
        return tuple(self._drawer.frame(episode, cleaning)
                     for episode, cleaning in zip(self.episodes, self._cleaning))

    def _observe(self) -> np.ndarray:
        mona = self.config.mona
        if self.batch is not None and not self.batch.done:  # every episode runs: one pass
            ground, ranges, is_robot = self.batch.sense()
            return spaces.observations(ground, ranges, is_robot, mona).reshape(
                self.num_envs, self.population, -1)
        # The episodes' last readings (each equals its rows of a batch's sense()).
        return np.stack([spaces.observations(r.ground, r.ranges, r.is_robot, mona)
                         for r in (episode.world.sense() for episode in self.episodes)])
