"""The swarm as learning environments: a PettingZoo ``ParallelEnv`` (one episode, one agent
per Mona) and a Gymnasium ``VectorEnv`` over the batched engine (K episodes stepped
together). Both drive the same engine as every run, so an action sequence gives the same
trajectory, metrics and bits as the embedded runner (docs/environments.md).

pettingzoo and gymnasium are imported only by the module that needs them.
"""

from swarm_supervisor.exports import lazy_exports

_WHERE = {
    **dict.fromkeys(('ACTION_SIZE', 'EnvError', 'commands_from_actions', 'observation_size',
                     'observations', 'reward'), 'spaces'),
    'MonaSwarmParallelEnv': 'parallel',
    'MonaSwarmVectorEnv': 'vector',
}
__all__ = sorted(_WHERE)
__getattr__, __dir__ = lazy_exports(__name__, _WHERE)
