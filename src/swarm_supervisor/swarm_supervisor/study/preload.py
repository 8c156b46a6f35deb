"""What the local pools' fork server imports before its first fork
(:mod:`swarm_supervisor.study.workers`): the episode engine and its writers, and numba's
compiler set up (its implementations registered, the runtime compiled: about 0.5 CPU-s that
every worker would spend again on its first kernel). Like any module of the packages, it
compiles no kernel when imported (tests/installed: the warm step's probe)."""

from __future__ import annotations

from numba.core.registry import cpu_target

from swarm_supervisor.study import tasks  # noqa: F401  (the engine, the episode writers)

cpu_target.target_context.refresh()
