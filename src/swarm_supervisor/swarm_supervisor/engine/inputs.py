"""What an episode reads before its first step, read up front: a command checks it before it
writes a byte or starts a process, so a bad input never costs a run.

Building the episode's first state is the check: the cue file (``world.cue_file``) is read and
scaled, the robots placed, the controllers made (a network's weights read), and every metric,
the user's registered ones too, taken once on that state. It is the engine's own code, so it
refuses exactly what the episode would have.
"""

from __future__ import annotations

from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.episode import Episode


def check_inputs(config: SwarmConfig) -> None:
    """Build the first state of an episode of ``config`` and take its metrics once.

    Raises:
        ParameterError: a file a parameter names is missing or not what it must be (a cue
            map's values outside 0..255, weights of another shape), or a metric returned no
            number (:class:`swarm_metrics.plugins.MetricError`, naming it).
        PlacementError: the robots do not fit in the arena.
    """
    Episode(config).metrics()
