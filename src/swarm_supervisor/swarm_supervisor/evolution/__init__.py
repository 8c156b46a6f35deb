"""Neuroevolution of the ``network`` controller on the batched engine (``mona-swarm evolve``):
the design (:mod:`.design`), the fitness of a generation (:mod:`.fitness`) and the resumable
CMA-ES loop (:mod:`.run`)."""

from swarm_supervisor.evolution.design import Design, EvolutionError, load_design
from swarm_supervisor.evolution.run import evolve

__all__ = ['Design', 'EvolutionError', 'evolve', 'load_design']
