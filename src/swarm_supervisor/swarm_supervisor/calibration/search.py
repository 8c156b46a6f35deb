"""The search: trials asked from optuna, their screening studies run, their scores told.

Optuna (TPE, seeded) proposes each trial's parameter values; the search keeps its state in
``DIR/calibration.db`` (SQLite), so an interrupted search resumes where it stopped. Trials are
asked ``batch`` at a time and the episodes of a batch share the worker processes (or the Dask
cluster) like one study's. Reproducible: trial n is always asked after trials 0 .. n - 1 of the
earlier batches are told, in trial order, from a sampler seeded with (seed, n); a trial asked
but not told when the search was interrupted is run again with the values it was given (its
finished episodes are kept), never asked anew, so an interrupted search equals an
uninterrupted one, trial for trial. For the same reason the number of trials is not part of
the design a folder holds: raised, the search carries on; lowered, it stops at the trials
asked for (those beyond are kept, and used again if it is raised).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import shutil
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from swarm_supervisor.analysis.claims import Claim
from swarm_supervisor.calibration.design import CalibrationDesign, CalibrationError, Range
from swarm_supervisor.calibration.objective import Score, score
from swarm_supervisor.outputs.lock import hold
from swarm_supervisor.study import plan, run_tasks, tidy_table, write_table
from swarm_supervisor.study.interrupt import raise_if_stopped
from swarm_supervisor.study.table import TABLE_FILE
from swarm_supervisor.study.workers import START_METHOD

STORAGE = 'calibration.db'
STUDY_NAME = 'calibration'
DIGEST_FILE = 'design.sha256'
TRIALS_DIR = 'trials'
TRIAL_FILE = 'trial.json'


@dataclasses.dataclass(frozen=True)
class TrialResult:
    """One scored trial."""

    number: int
    values: dict[str, Any]  #: the searched parameters' values
    score: Score

    def to_json(self) -> str:
        """The trial as the JSON its folder keeps."""
        return json.dumps({'number': self.number, 'values': self.values,
                           'score': dataclasses.asdict(self.score)}, indent=2) + '\n'

    @classmethod
    def from_json(cls, text: str) -> TrialResult:
        """A trial read back from :meth:`to_json`'s text."""
        document = json.loads(text)
        stored = document['score']
        return cls(document['number'], document['values'],
                   Score(tuple(stored['held']), tuple(stored['failed']), stored['ratio'],
                         stored['f_values'], stored['loss']))


def distribution(parameter: Range):
    """The optuna distribution of a parameter's range."""
    import optuna.distributions as dist

    if parameter.kind == 'choice':
        return dist.CategoricalDistribution(parameter.choices)
    if parameter.kind == 'int':
        return dist.IntDistribution(int(parameter.low), int(parameter.high), log=parameter.log,
                                    step=1 if parameter.log else parameter.step)
    return dist.FloatDistribution(parameter.low, parameter.high, log=parameter.log)


def trial_seed(seed: int, number: int) -> int:
    """The sampler's seed for trial ``number`` of a search seeded ``seed``."""
    digest = hashlib.sha256(f'{seed}:{number}'.encode()).digest()
    return int.from_bytes(digest[:4], 'little')


def open_search(design: CalibrationDesign, out: Path):
    """The optuna study of ``out`` (created, or resumed when it is this design's).

    Raises:
        CalibrationError: ``out`` holds the search of another design (or another base config).
    """
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    hold(out)  # created, and locked while the search runs
    marker = out / DIGEST_FILE
    if marker.exists() and marker.read_text().strip() != design.digest:
        raise CalibrationError(f'{out} holds the search of another design (or of another '
                               'parameter file); use another --out folder')
    if not marker.exists() and (out / STORAGE).exists():
        raise CalibrationError(f'{out / STORAGE} belongs to no known design; use another '
                               '--out folder')
    study = optuna.create_study(study_name=STUDY_NAME, storage=f'sqlite:///{out / STORAGE}',
                                direction='minimize', load_if_exists=True)
    marker.write_text(design.digest + '\n')
    return study


def trial_dir(out: Path, number: int) -> Path:
    """The folder of trial ``number`` under the calibration folder ``out``."""
    return out / TRIALS_DIR / f'{number:04d}'


def run_search(design: CalibrationDesign, out: Path, claims: Sequence[Claim], *,
               jobs: int | None = None, scheduler: str | None = None,
               scheduler_timeout: float = 30.0, start_method: str = START_METHOD,
               keep_episodes: bool = False,
               say: Callable[[str], None] = lambda line: print(line, file=sys.stderr)
               ) -> list[TrialResult]:
    """Run (or resume) the screening search of ``design`` into ``out``.

    Returns:
        Every trial's result, in trial order.
    """
    from optuna.trial import TrialState

    study = open_search(design, out)
    distributions = {p.key: distribution(p) for p in design.parameters}
    while True:
        # A batch asked but not told (an interrupted search) is run again with its values;
        # trials beyond the design's count (it was lowered) are left as they are.
        batch = [(t.number, dict(t.params)) for t in
                 study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))
                 if t.number < design.trials]
        told = sum(t.number < design.trials for t in
                   study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)))
        if not batch:
            if told >= design.trials:
                break
            for _ in range(min(design.batch, design.trials - told)):
                study.sampler = _sampler(design, len(study.trials))
                trial = study.ask(distributions)
                batch.append((trial.number, dict(trial.params)))
        else:
            say(f'resuming trials {", ".join(str(n) for n, _ in batch)} (asked before the '
                'search was interrupted)')
        raise_if_stopped()
        results = evaluate(design, out, batch, claims, jobs=jobs, scheduler=scheduler,
                           scheduler_timeout=scheduler_timeout, start_method=start_method,
                           keep_episodes=keep_episodes)
        for result in sorted(results, key=lambda r: r.number):
            raise_if_stopped()
            study.tell(result.number, result.score.loss)
            best = min(load_results(out, design.trials),
                       key=lambda r: (r.score.loss, r.number))
            say(f'trial {result.number} ({result.number + 1} of {design.trials}): loss '
                f'{result.score.loss:.3f} '
                f'({len(result.score.held)}/{len(result.score.held) + len(result.score.failed)} '
                f'claims, ratio {result.score.ratio:.3g}) {_values_text(result.values)}; '
                f'best so far: trial {best.number} ({best.score.loss:.3f})')
    return load_results(out, design.trials)


def _sampler(design: CalibrationDesign, number: int):
    import optuna

    return optuna.samplers.TPESampler(seed=trial_seed(design.seed, number),
                                      n_startup_trials=design.startup)


def _values_text(values: dict[str, Any]) -> str:
    return ', '.join(f'{key} = {value:.4g}' if isinstance(value, float) else f'{key} = {value}'
                     for key, value in values.items())


def evaluate(design: CalibrationDesign, out: Path, batch: Sequence[tuple[int, dict[str, Any]]],
             claims: Sequence[Claim], *, jobs: int | None = None,
             scheduler: str | None = None, scheduler_timeout: float = 30.0,
             start_method: str = START_METHOD, keep_episodes: bool = False) -> list[TrialResult]:
    """Run the screening studies of a batch of trials together and score each one; each
    trial's folder keeps trial.json and its all_metrics.csv (its episodes only with
    ``keep_episodes``; the episodes it deletes get no picture)."""
    planned, tasks, scored = [], [], []
    for number, values in batch:
        folder = trial_dir(out, number)
        if (folder / TRIAL_FILE).exists():  # scored, but the search stopped before telling
            scored.append(TrialResult.from_json((folder / TRIAL_FILE).read_text()))
            continue
        config = design.trial_config(values, design.screen)
        specs, folders, pending = plan(config, folder, picture=keep_episodes)
        planned.append((number, values, folder, [folders[spec] for spec in specs]))
        tasks += pending
    run_tasks(tasks, jobs=jobs, progress=False, start_method=start_method,
              scheduler=scheduler, scheduler_timeout=scheduler_timeout)
    results = scored
    for number, values, folder, episodes in planned:
        table = tidy_table(episodes, factors=())
        write_table(table, folder / TABLE_FILE)
        result = TrialResult(number, values, score(table, claims, design.objective))
        temporary = folder / (TRIAL_FILE + '.tmp')  # whole or absent, if interrupted
        temporary.write_text(result.to_json())
        os.replace(temporary, folder / TRIAL_FILE)
        if not keep_episodes:
            shutil.rmtree(episodes[0].parent, ignore_errors=True)
        results.append(result)
    return results


def load_results(out: Path, count: int | None = None) -> list[TrialResult]:
    """The scored trials of a search folder, in trial order (only trials 0 .. count - 1 if
    ``count`` is given)."""
    results = (TrialResult.from_json(path.read_text())
               for path in (out / TRIALS_DIR).glob(f'*/{TRIAL_FILE}'))
    return sorted((r for r in results if count is None or r.number < count),
                  key=lambda r: r.number)
