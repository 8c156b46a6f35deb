"""The swarm as a PettingZoo ``ParallelEnv``: one episode, one agent per Mona.

Agents ``mona_0`` .. ``mona_<N-1>`` (every robot acts at once; none leaves before the end).
A step is one control period (``world.control_steps`` world steps of ``world.step_period``):
the agents' actions drive the wheels and cleaners for that long, as a controller's answer
would. Observations, actions and the reward: :mod:`swarm_supervisor.envs.spaces`. The reward
is **shared**: every agent gets the cue the swarm removed in the step (a share of the initial
cue), so the return of an episode is the share of the cue it cleaned. The episode ends by
time only (``episode.duration``): every agent is *truncated* then, never *terminated*.

Same config, same seed and same actions give the same bits as the embedded runner: with
BEECLUST's answers as actions, :attr:`MonaSwarmParallelEnv.metrics` equals
``run_episode(config).metrics`` (tests/unit/test_envs.py).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.spaces import Box
from pettingzoo import ParallelEnv

from swarm_metrics.metrics import mean_cue
from swarm_supervisor.config import SwarmConfig, load_config
from swarm_supervisor.engine.episode import Episode
from swarm_supervisor.envs.render import (
    RENDER_MODES,
    FrameDrawer,
    check_render_mode,
    no_mode_warning,
)
from swarm_supervisor.envs.spaces import (
    ACTION_SIZE,
    EnvError,
    commands_from_actions,
    observation_size,
    observations,
    reward,
)
from swarm_world.world import Readings


def agent_spaces(config: SwarmConfig) -> tuple[Box, Box]:
    """One agent's observation and action spaces (float64 Boxes)."""
    top = config.mona.max_wheel_command
    observed = Box(0.0, 1.0, shape=(observation_size(config.mona),), dtype=np.float64)
    acting = Box(np.array([-top, -top, 0.0]), np.array([top, top, 1.0]),
                 shape=(ACTION_SIZE,), dtype=np.float64)
    return observed, acting


class MonaSwarmParallelEnv(ParallelEnv):
    """N Monas cleaning one leak (the parameter file's episode), as PettingZoo agents."""

    metadata = {'name': 'mona_swarm_v0', 'render_modes': RENDER_MODES,
                'is_parallelizable': True}

    def __init__(self, config: SwarmConfig | None = None,
                 render_mode: str | None = None) -> None:
        """``config``: the episode (default: the shipped parameter file); ``render_mode``:
        'rgb_array' for :meth:`render`'s frames, None for none."""
        self.render_mode = check_render_mode(render_mode)
        self.config = config if config is not None else load_config()
        population = self.config.episode.population
        if population < 1:
            raise EnvError('episode.population must be at least 1 for an environment')
        self.possible_agents = [f'mona_{i}' for i in range(population)]
        self.agents: list[str] = []
        self._observed, self._acting = agent_spaces(self.config)
        self.episode: Episode | None = None
        #: The metrics rows so far (t = 0 and every sample boundary), as run_episode's.
        self.metrics: list[dict[str, float]] = []
        #: The robots' readings behind the latest observations (raw, for a controller).
        self.readings: Readings | None = None
        self._initial = self._mean = 0.0
        #: The seed of the next unseeded reset (each reset takes the next one).
        self._next_seed = self.config.episode.seed
        self._cleaning = np.zeros(population, dtype=bool)
        self._drawer: FrameDrawer | None = None

    def observation_space(self, agent: str) -> Box:
        """Every agent's observation space (see :mod:`~swarm_supervisor.envs.spaces`)."""
        return self._observed

    def action_space(self, agent: str) -> Box:
        """Every agent's action space: left and right wheel commands, cleaner."""
        return self._acting

    def reset(self, seed: int | None = None,
              options: dict | None = None) -> tuple[dict[str, np.ndarray], dict[str, dict]]:
        """Start a new episode: from ``seed`` if given, else from the seed after the last
        episode's (the first from ``episode.seed``), so one seed fixes the whole sequence and
        every unseeded reset is a fresh episode, as Gymnasium's convention has it; placement,
        cue and every stream as a run with that seed."""
        if seed is not None:
            self._next_seed = seed
        if self.episode is None:
            self.episode = Episode(self.config)
        self.episode.reset(self._next_seed)
        self._next_seed += 1
        self._cleaning[:] = False
        self.agents = list(self.possible_agents)
        self.metrics = [self.episode.metrics()]
        self._initial = self._mean = mean_cue(self.episode.world.field.cue)
        return self._observe(), {agent: {} for agent in self.agents}

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        """Drive every robot with its action for one control period.

        Raises:
            EnvError: the episode is over (call reset), or an agent's action is missing.
        """
        episode = self.episode
        if episode is None or not self.agents:
            raise EnvError('the episode is over or not started: call reset()')
        missing = [agent for agent in self.agents if agent not in actions]
        if missing:
            raise EnvError(f'no action for {", ".join(missing[:3])}'
                           + (f' and {len(missing) - 3} more' if len(missing) > 3 else ''))
        command = commands_from_actions(np.stack([np.asarray(actions[agent], dtype=np.float64)
                                                  for agent in self.agents]), self.config.mona)
        self._cleaning = command.cleaner
        for _ in range(episode.control_steps):
            if episode.drive(command).sampled:
                self.metrics.append(episode.metrics())
            if episode.done:
                break
        now = mean_cue(episode.world.field.cue)
        shared = reward(self._mean, now, self._initial)
        self._mean = now
        over = episode.done
        observed = self._observe()
        agents = self.agents
        if over:
            self.agents = []
        return (observed, dict.fromkeys(agents, shared), dict.fromkeys(agents, False),
                dict.fromkeys(agents, over), {agent: {} for agent in agents})

    def _observe(self) -> dict[str, np.ndarray]:
        assert self.episode is not None
        self.readings = readings = self.episode.world.sense()
        rows = observations(readings.ground, readings.ranges, readings.is_robot,
                            self.config.mona)
        return {agent: rows[i] for i, agent in enumerate(self.possible_agents)}

    def render(self) -> np.ndarray | None:
        """With ``render_mode='rgb_array'``: the current state as the episode video's frame,
        [H, W, 3] uint8 (:mod:`~swarm_supervisor.envs.render`); without a mode: None, and a
        warning."""
        if self.render_mode is None:
            no_mode_warning()
            return None
        if self.episode is None:
            raise EnvError('call reset() before render()')
        if self._drawer is None:
            self._drawer = FrameDrawer(self.config)
        return self._drawer.frame(self.episode, self._cleaning)

    def state(self) -> np.ndarray:
        """The global state: every robot's pose [N, 3] (x m, y m, yaw rad), flattened."""
        assert self.episode is not None, 'call reset() first'
        return self.episode.world.poses.astype(np.float64).ravel()
