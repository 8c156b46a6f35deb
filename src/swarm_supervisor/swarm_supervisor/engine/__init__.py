"""The engine: an episode stepped in one process, many stepped together, and the runner that
collects their results (pure: no ROS)."""

from swarm_supervisor.engine.batch import Batch, BatchError, batch_key
from swarm_supervisor.engine.episode import PARTS, Episode, Step, place_swarm
from swarm_supervisor.engine.runner import (
                                            EpisodeObserver,
                                            EpisodeResult,
                                            Pacer,
                                            run_batch,
                                            run_episode,
)

__all__ = ['Batch', 'BatchError', 'Episode', 'EpisodeObserver', 'EpisodeResult', 'PARTS',
           'Pacer', 'Step', 'batch_key', 'place_swarm', 'run_batch', 'run_episode']
