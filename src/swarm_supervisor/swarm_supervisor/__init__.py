"""The Mona swarm's supervisor package: episodes, studies, analysis, media, the node system.

Sub-packages, each with one job and a public face (its ``__init__``), from the bottom up:

- ``config``: the whole parameter set and the YAML both runners read;
- ``engine``: the episode engine, the batched engine and the embedded runner;
- ``outputs``: an episode's folder, its embedded bag and its pictures;
- ``media``: videos of bags and the Foxglove live view;
- ``study``: designs, running them on local processes or a Dask cluster, the tidy table;
- ``analysis``: figures, ANOVA, the paper's claims, sensitivity and report.md;
- ``system``: the node system: the supervisor and live nodes, the launcher, processes,
  replay onto ROS topics;
- ``cli``: the one command, ``mona-swarm`` (``scripts/swarm.sh`` runs ``mona-swarm launch``).

A module imports only from its own sub-package and those listed before it
(tests/unit/test_layers.py).
"""

__version__ = '0.1.0'
__all__ = ['__version__']
