"""The evolution loop: an optimiser over the net's weights (CMA-ES or OpenAI-ES,
:mod:`swarm_supervisor.evolution.strategies`), resumable per generation.

Each generation the optimiser proposes ``genomes`` weight vectors, every one is scored on the
generation's training seeds (:mod:`swarm_supervisor.evolution.fitness`) and the optimiser is
told the scores. pycma draws its samples from numpy's global generator, seeded through its own
``seed`` option; the loop keeps that generator's state apart (restored before each ``ask``),
so nothing else in the process moves it. After each generation ``checkpoint.pkl`` is
replaced atomically (``os.replace``): the pickled optimiser, the generator's state, the
generation and the rows of ``generations.csv``. A run started on a folder with a checkpoint
of the same design carries on from it, so the same seed and design give the same run,
interrupted or not (wall times aside). The episodes run in this process, on a pool of
worker processes (``jobs``, :mod:`swarm_supervisor.study.workers`) or on the workers of a
Dask scheduler (``scheduler``, :mod:`swarm_supervisor.evolution.cluster`), with the same
scores on each.

With ``validation`` > 0 the optimiser's mean is scored on a fixed validation set every
``validate_every`` generations (:mod:`swarm_supervisor.evolution.validation`), and the run
stops early once ``patience`` validations in a row have not improved on the best.

Outputs in the folder: ``generations.csv`` (generation, best, mean, worst, sigma, wall_s,
and with validation the mean's ``validation`` score where it was validated),
``fitness.png``, ``best.npz`` (as weights: the best genome evaluated so far, or with
validation the mean of the best validation), ``chosen.json`` (with validation: which
generation's mean best.npz is and its score), ``design.yaml`` (the design's checked values)
and ``genomes/`` (the current generation's weights files); with ``held_out`` > 0, the
post-evaluation's compare.csv, compare.json and compare.png
(:mod:`swarm_supervisor.evolution.compare`).
"""

from __future__ import annotations

import csv
import json
import os
import pickle
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from tqdm import tqdm

from swarm_supervisor.evolution import strategies, validation
from swarm_supervisor.evolution.cluster import ClusterPool
from swarm_supervisor.evolution.design import Design, EvolutionError
from swarm_supervisor.evolution.fitness import evaluate
from swarm_supervisor.evolution.genomes import save_genome, start_genome
from swarm_supervisor.outputs.lock import hold
from swarm_supervisor.study import workers
from swarm_supervisor.study.cluster import CONNECT_TIMEOUT
from swarm_supervisor.study.interrupt import raise_if_stopped

#: The columns of generations.csv.
COLUMNS = ('generation', 'best', 'mean', 'worst', 'sigma', 'wall_s')
CHECKPOINT = 'checkpoint.pkl'


def new_strategy(design: Design) -> Any:
    """The design's seeded optimiser (:mod:`.strategies`), its mean at the design's start
    (:func:`~swarm_supervisor.evolution.genomes.start_genome`)."""
    return strategies.new_strategy(design.strategy, start_genome(design), design.sigma,
                                   design.genomes, design.seed, design.learning_rate,
                                   design.diagonal)


def columns(design: Design) -> tuple[str, ...]:
    """generations.csv's columns for ``design`` (``validation`` only where it validates)."""
    return (*COLUMNS, 'validation') if design.validation else COLUMNS


def write_atomically(path: Path, data: bytes) -> None:
    """Replace ``path`` by ``data`` in one step (a crash leaves the old or the new file)."""
    tmp = path.with_name(path.name + '.tmp')
    tmp.write_bytes(data)
    os.replace(tmp, path)


def load_checkpoint(out: Path, design: Design) -> dict[str, Any] | None:
    """The checkpoint in ``out`` (None if there is none).

    Raises:
        EvolutionError: it belongs to another design.
    """
    path = out / CHECKPOINT
    if not path.is_file():
        return None
    state = pickle.loads(path.read_bytes())
    if state['digest'] != design.digest():
        raise EvolutionError(f'{out} holds an evolution of another design (or base '
                             'parameters); use another --out')
    return state


def write_csv(out: Path, rows: list[dict[str, float]],
              names: tuple[str, ...] = COLUMNS) -> None:
    """generations.csv, every generation so far (an empty cell where a row lacks a value)."""
    lines = [','.join(names)] + [','.join(repr(row[c]) if c in row else '' for c in names)
                                 for row in rows]
    write_atomically(out / 'generations.csv', ('\n'.join(lines) + '\n').encode())


def read_csv(path: Path) -> list[dict[str, str]]:
    """generations.csv's rows (for tests and reports)."""
    with path.open() as handle:
        return list(csv.DictReader(handle))


def plot(out: Path, rows: list[dict[str, float]]) -> Path:
    """fitness.png: best, mean and worst fitness per generation."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(6, 3.5))
    x = [row['generation'] for row in rows]
    for column, style in (('best', '-'), ('mean', '--'), ('worst', ':')):
        axes.plot(x, [row[column] for row in rows], style, label=column)
    validated = [row for row in rows if 'validation' in row]
    if validated:
        axes.plot([row['generation'] for row in validated],
                  [row['validation'] for row in validated], 'o-', markersize=3,
                  label="the optimiser's mean, validation")
    axes.set_xlabel('generation')
    axes.set_ylabel('mean cue fraction (lower is better)')
    axes.legend()
    figure.tight_layout()
    path = out / 'fitness.png'
    figure.savefig(path, dpi=120)
    plt.close(figure)
    return path


def save_best(out: Path, design: Design, genome: np.ndarray) -> str:
    """best.npz from a genome; its SHA-256."""
    return save_genome(design, genome, out / 'best.npz')


def save_chosen(out: Path, design: Design, state: dict[str, Any]) -> None:
    """best.npz: the mean of the best validation (and chosen.json, which one), or without
    validation the best genome evaluated."""
    if not design.validation:
        save_best(out, design, state['best'][1])
        return
    if state['chosen'] is None:
        return  # nothing validated yet
    score, mean, generation = state['chosen']
    digest = save_best(out, design, mean)
    write_atomically(out / 'chosen.json', (json.dumps({
        'generation': generation, 'validation': score,
        'validation_seeds': validation.validation_seeds(design),
        'best_npz_sha256': digest}, indent=2) + '\n').encode())


def evolve(design: Design, out: Path, *, jobs: int = 1, scheduler: str | None = None,
           scheduler_timeout: float = CONNECT_TIMEOUT, shown: bool | None = None,
           on_checkpoint: Any = None) -> list[dict[str, float]]:
    """Run (or resume) the evolution of ``design`` in ``out``; the rows of generations.csv.

    ``jobs`` > 1 scores the episodes on that many worker processes; ``scheduler``
    (a Dask scheduler's address) on that cluster's workers instead (:mod:`.cluster`), the
    same scores; ``shown`` shows the progress bar (None: only on a terminal).

    Raises:
        EvolutionError: ``out`` holds another design's run, or more generations.
        ClusterError: the scheduler does not answer (before anything is written).
    """
    if scheduler is not None:
        cluster = ClusterPool(scheduler, scheduler_timeout)
        try:
            rows = _evolve(design, out, cluster, cluster.jobs, shown, on_checkpoint)
        except BaseException:
            cluster.terminate()  # cancels what is still pending
            raise
        cluster.close()
        return rows
    pool = workers.pool(jobs) if jobs > 1 else None
    try:
        rows = _evolve(design, out, pool, jobs, shown, on_checkpoint)
    except BaseException:
        if pool is not None:
            pool.terminate()
        raise
    else:
        if pool is not None:
            pool.close()
    finally:
        if pool is not None:
            pool.join()
    return rows


def _evolve(design: Design, out: Path, pool: Any | None, jobs: int, shown: bool | None,
            on_checkpoint: Any) -> list[dict[str, float]]:
    """The loop of :func:`evolve` on ``pool`` (None: this process) of ``jobs`` workers."""
    hold(out)  # created, and locked while the evolution runs
    state = load_checkpoint(out, design)
    if state is None:
        strategy = new_strategy(design)
        state = {'digest': design.digest(), 'strategy': strategy, 'generation': 0,
                 'random': np.random.get_state(), 'rows': [], 'best': None,
                 'validations': [], 'chosen': None}
    else:
        state.setdefault('validations', [])  # a checkpoint of a run before validation
        state.setdefault('chosen', None)
    if state['generation'] > design.generations:
        raise EvolutionError(f'{out} holds {state["generation"]} generations, more than '
                             f'evolve.generations = {design.generations}; raise it to '
                             'resume, or set it to the generations done')
    # Rewritten each run: a resumed run may have raised (or cut) evolve.generations.
    (out / 'design.yaml').write_text(yaml.safe_dump({'evolve': design.to_dict()},
                                                    sort_keys=False))
    strategy, rows = state['strategy'], state['rows']
    disable = None if shown is None else not shown
    with tqdm(total=design.generations, initial=state['generation'], desc='generations',
              unit='gen', disable=disable, file=sys.stderr) as bar:
        for generation in range(state['generation'], design.generations):
            raise_if_stopped()  # a signal whose exception was swallowed (docs/study.md)
            if validation.stopped(design, state['validations']):
                break  # the validation score has stopped improving
            started = time.perf_counter()
            np.random.set_state(state['random'])
            genomes = np.array(strategy.ask())
            scores = evaluate(design, genomes, generation, out / 'genomes', pool, jobs)
            strategy.tell(list(genomes), scores)
            best = int(np.argmin(scores))
            if state['best'] is None or scores[best] < state['best'][0]:
                state['best'] = (scores[best], genomes[best].copy())
            row = {'generation': generation, 'best': min(scores),
                   'mean': float(np.mean(scores)), 'worst': max(scores),
                   'sigma': float(strategy.sigma)}
            if validation.due(design, generation):
                mean = np.array(strategy.mean, dtype=np.float64)
                row['validation'] = validation.validate(design, mean, out / 'genomes', pool,
                                                        jobs)
                state['validations'].append((generation, row['validation']))
                if state['chosen'] is None or row['validation'] < state['chosen'][0]:
                    state['chosen'] = (row['validation'], mean, generation)
            row['wall_s'] = round(time.perf_counter() - started, 3)
            rows.append(row)
            state.update(generation=generation + 1, random=np.random.get_state())
            save_chosen(out, design, state)
            write_csv(out, rows, columns(design))
            write_atomically(out / CHECKPOINT, pickle.dumps(state))
            bar.update(1)
            bar.set_postfix(best=f'{state["best"][0]:.4f}')
            if on_checkpoint is not None:
                on_checkpoint(generation)
    if design.held_out and not (out / 'compare.json').exists():
        from swarm_supervisor.evolution.compare import compare

        compare(design, out, pool, jobs)
    plot(out, rows)
    return rows
