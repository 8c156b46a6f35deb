"""The study as data: populations x speeds x extra factors x seeds, run in parallel,
resumable, as one table.

Any parameter of the schema can be an extra factor (``study.factors``, e.g.
``mona.ir_range: [0.02, 0.05]``), crossed with the others or, for a sensitivity design,
varied one at a time (``study.factor_design``). Each episode of the design gets a folder
``DIR/episodes/N<pop>_v<cm/s>_s<seed>[_<key>=<level>...]/`` written by
:func:`swarm_supervisor.outputs.write_episode`; its episode.json is written last, so a folder
without it is half-written and is run again, while a complete one is kept. The episodes of a
study (or any folders holding metrics.csv + episode.json, e.g. from ROS bags) become one tidy
table, ``all_metrics.csv``, with one row per episode and sample::

    population, speed, seed, [factors...,] t, mean_cue, mean_cue_fraction, ratio_near_source,
    coherency

where each extra factor is a column named by its dotted key.

``speed`` is in m/s, like every speed in the parameter file.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import multiprocessing
import os
import shutil
import signal
import sys
import time
import traceback
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import pandas as pd
from tqdm import tqdm

from mona_controller.schema import ParameterError
from swarm_metrics.completeness import Finding, check_rows
from swarm_metrics.metrics import COLUMNS, is_source_column
from swarm_supervisor import outputs
from swarm_supervisor.config import DESIGN_KEYS, StudyParams, SwarmConfig, write_ros_yaml
from swarm_supervisor.batch import batch_key
from swarm_supervisor.runner import run_batch

EPISODES_DIR = 'episodes'
BAG_DIR = 'bag'  #: an episode's bag, inside its folder (``study --bag``)
VIDEOS_DIR = 'videos'  #: one video per design cell (``study --videos``)
TABLE_FILE = 'all_metrics.csv'
PARAMETERS_FILE = 'parameters.yaml'
TIMING_FILE = 'study.json'
KEYS = ('population', 'speed', 'seed')
TABLE_COLUMNS = KEYS + COLUMNS
#: Episodes a worker steps together by default (``--batch-size``): on the 2-core development
#: machine the per-episode speed grows up to about 16 (N = 10: 390x alone, 1050x in 16s; N =
#: 50: 240x, 480x) and no further (64: the same or a little slower, caches), and a batch of 16
#: holds about 25 MB of cue maps and snapshots.
DEFAULT_BATCH_SIZE = 16


class StudyError(ParameterError):
    """The study's folder or episodes do not fit the requested design."""


class EpisodeFailed(RuntimeError):
    """An episode raised in a worker; the message names it and holds the worker's traceback."""


@dataclasses.dataclass(frozen=True)
class EpisodeSpec:
    """One cell of the design and one repetition in it."""

    population: int
    speed: float  #: m/s
    seed: int
    #: The extra factors' values in this episode, (dotted key, value) in declared order.
    levels: tuple[tuple[str, Any], ...] = ()
    #: The levels that name the episode: all of them in a crossed design, only the one that
    #: differs from the parameter file in a one-at-a-time design.
    named: tuple[tuple[str, Any], ...] = ()

    @property
    def name(self) -> str:
        """The episode's folder name, e.g. ``N30_v8_s1`` (speed in cm/s), followed by its
        named factor levels, e.g. ``N30_v8_s1_mona.ir_range=0.05``."""
        return f'N{self.population}_v{self.speed * 100:g}_s{self.seed}' + ''.join(
            f'_{key}={_level_text(value)}' for key, value in self.named)


def _level_text(value: Any) -> str:
    """A factor level in a folder name: the shortest exact text of a number."""
    return repr(value) if isinstance(value, float) else str(value)


def factor_cells(config: SwarmConfig) -> list[tuple[tuple[tuple[str, Any], ...],
                                                   tuple[tuple[str, Any], ...]]]:
    """The combinations of extra factor levels: (levels, named levels) of each.

    Crossed: every combination. One-at-a-time: the parameter file's values, then each level
    of each factor that differs from them with the other factors at the file's values.
    """
    study = config.study
    if not study.factors:
        return [((), ())]
    base = tuple((key, parameter_value(config, key)) for key in study.factor_names)
    if study.factor_design == 'crossed':
        cells = itertools.product(*([(key, v) for v in values] for key, values in study.factors))
        return [(cell, cell) for cell in map(tuple, cells)]
    cells = [(base, ())]
    for index, (key, values) in enumerate(study.factors):
        for value in values:
            if value != base[index][1]:
                cell = base[:index] + ((key, value),) + base[index + 1:]
                cells.append((cell, ((key, value),)))
    return cells


def parameter_value(config: SwarmConfig, key: str) -> Any:
    """The value of a dotted parameter key, e.g. ``mona.ir_range``."""
    section, _, name = key.partition('.')
    return getattr(getattr(config, section), name)


def design(config: SwarmConfig) -> list[EpisodeSpec]:
    """Every episode of the study's design, in factor order: populations, speeds, the extra
    factors (:func:`factor_cells`), then seeds."""
    study = config.study
    return [EpisodeSpec(n, v, s, levels, named)
            for n, v, (levels, named), s in itertools.product(
                study.populations, study.speeds, factor_cells(config), study.seeds)]


def quick_study(study: StudyParams) -> StudyParams:
    """A reduced design for a smoke test: N = 5 and 10, the same speeds and extra factors,
    two seeds, 60 s.

    The snapshot times are scaled from the full duration to the short one, so fig. 3 still
    shows the start, an intermediate and the end of the episode.
    """
    duration = 60.0
    scale = duration / study.duration
    return dataclasses.replace(
        study, populations=(5, 10), seeds=study.seeds[:2], duration=duration,
        snapshot_times=tuple(sorted({round(t * scale, 3) for t in study.snapshot_times})))


def episode_config(config: SwarmConfig, spec: EpisodeSpec) -> SwarmConfig:
    """The full configuration of one episode of ``config.study``."""
    sections: dict[str, dict[str, Any]] = {
        'episode': {'population': spec.population, 'seed': spec.seed,
                    'duration': config.study.duration},
        'controller': {'speed': spec.speed}}
    for key, value in spec.levels:
        section, _, name = key.partition('.')
        sections.setdefault(section, {})[name] = value
    return config.replace(**sections)


def snapshot_times(study: StudyParams) -> tuple[float, ...]:
    """When each episode keeps a cue map: the study's times within the episode, and its end."""
    return tuple(sorted({t for t in study.snapshot_times if t <= study.duration}
                        | {study.duration}))


# Worker side: each worker runs whole episodes and writes them; only small tuples come back.

_progress_counter = None  # sim seconds done, shared by every worker (a multiprocessing Value)
_PROGRESS_STEP = 10.0  # s of sim time between counter updates (the counter takes a lock)


def _init_worker(counter) -> None:
    """Pool initializer: share the progress counter; leave Ctrl-C to the parent."""
    global _progress_counter
    _progress_counter = counter
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _report_progress(seconds: float) -> None:
    if _progress_counter is not None and seconds > 0:
        with _progress_counter.get_lock():
            _progress_counter.value += seconds


def _run_and_write(task: tuple[SwarmConfig, tuple[float, ...], str, bool]
                   ) -> tuple[str, float, float]:
    """Run one episode and write its folder (with its bag in ``bag/`` if the task's last item
    is true); return (folder, wall s, CPU s), with writing."""
    return _run_batch_and_write((task,))[0]


def _run_batch_and_write(tasks: Sequence[tuple[SwarmConfig, tuple[float, ...], str, bool]]
                         ) -> list[tuple[str, float, float]]:
    """Run the episodes of ``tasks`` as one batch (:func:`~swarm_supervisor.runner.run_batch`;
    they share the snapshot times) and write each one's folder as soon as it is done, so an
    interrupted batch loses only its unfinished episodes.

    Returns:
        (folder, wall s, CPU s) per task: each episode's share of the batch's times, writing
        included.
    """
    started, cpu = time.perf_counter(), time.process_time()
    reported = [0.0] * len(tasks)
    names = ', '.join(task[2] for task in tasks)

    def progress(k: int, t: float) -> None:
        if t - reported[k] >= _PROGRESS_STEP:
            _report_progress(t - reported[k])
            reported[k] = t

    try:
        recorders: list = [None] * len(tasks)
        if any(task[3] for task in tasks):
            from swarm_supervisor.record import BagRecorder  # the bag's libraries, if asked
            for k, (_, _, folder, bag) in enumerate(tasks):
                if bag:
                    shutil.rmtree(Path(folder) / BAG_DIR, ignore_errors=True)  # half-written
                    recorders[k] = BagRecorder(folder)

        def finished(k: int, result) -> None:
            config, _, folder, _ = tasks[k]
            extra = None
            if recorders[k] is not None:
                recorders[k].check(result)
                extra = {'bag': BAG_DIR}
            _report_progress(config.episode.duration - reported[k])
            outputs.write_episode(result, folder, extra=extra)

        run_batch([task[0] for task in tasks], snapshot_times=tasks[0][1], progress=progress,
                  observers=[[] if r is None else [r] for r in recorders], finished=finished)
    except Exception:  # the traceback does not survive the trip to the parent otherwise
        raise EpisodeFailed(f'episode {names} failed:\n{traceback.format_exc()}') from None
    share = len(tasks)
    return [(task[2], (time.perf_counter() - started) / share,
             (time.process_time() - cpu) / share) for task in tasks]


def make_batches(pending: Sequence[tuple[SwarmConfig, tuple[float, ...], str, bool]],
                 batch_size: int, jobs: int
                 ) -> list[tuple[tuple[SwarmConfig, tuple[float, ...], str, bool], ...]]:
    """Group the episode tasks into batches of at most ``batch_size`` that can be stepped
    together (:func:`~swarm_supervisor.batch.batch_key`), at least ``jobs`` batches when
    there are that many episodes (every worker gets work), the costliest first.

    Within a group, episodes are dealt out in turn, costliest first, so the batches of a
    group cost about the same and the workers finish together.
    """
    groups: dict[tuple[int, int], list] = {}
    for task in pending:
        groups.setdefault(batch_key(task[0]), []).append(task)
    batches = []
    for tasks in groups.values():
        tasks = sorted(tasks, key=lambda task: -_cost(task))
        count = max(-(-len(tasks) // batch_size), min(jobs, len(tasks)))
        batches += [tuple(tasks[k::count]) for k in range(count)]
    return sorted(batches, key=lambda batch: -sum(map(_cost, batch)))


def _cost(task: tuple[SwarmConfig, Any, Any, Any]) -> float:
    """An episode's cost, roughly: robot-seconds."""
    return max(task[0].episode.population, 1) * task[0].episode.duration


# Parent side.

def _expected_parameters(config: SwarmConfig) -> dict[str, Any]:
    """The parameters as episode.json stores them (after a JSON round trip)."""
    return json.loads(json.dumps(config.to_dict()))


def _check_kept(folder: Path, config: SwarmConfig) -> None:
    """Refuse to mix a finished episode run with other parameters into this study."""
    record = json.loads((folder / outputs.EPISODE_FILE).read_text())
    stored = record.get('parameters', {})
    expected = _expected_parameters(config)
    for section, values in expected.items():
        if section == 'study':  # the design around the episode does not change it
            continue
        for key, value in values.items():
            if stored.get(section, {}).get(key) != value:
                raise StudyError(
                    f'{folder} was run with {section}.{key} = '
                    f'{stored.get(section, {}).get(key)!r}, this study needs {value!r}; '
                    'use another --out folder or delete that episode')


def run_study(config: SwarmConfig, out_dir: str | Path, *, jobs: int | None = None,
              progress: bool | None = None, start_method: str = 'spawn',
              scheduler: str | None = None, scheduler_timeout: float = 30.0,
              bag: bool = False, videos: bool = False,
              batch_size: int = DEFAULT_BATCH_SIZE) -> list[dict[str, float]]:
    """Run every missing episode of ``config.study`` into ``out_dir`` and tabulate them all.

    Episodes already complete in ``out_dir/episodes`` are kept (after checking they were run
    with the same parameters); the others run in batches of at most ``batch_size`` episodes
    stepped together (:mod:`swarm_supervisor.batch`), costliest first, over ``jobs`` worker
    processes; each episode is written as soon as it is done.
    Writes ``parameters.yaml`` (the configuration), ``study.json`` (what ran, wall times) and
    ``all_metrics.csv``. Ctrl-C terminates the workers; finished episodes stay on disk and the
    next call resumes from them.

    Args:
        jobs: worker processes (default: the CPUs this process may use).
        progress: show progress bars on stderr (None: only on a terminal).
        start_method: the multiprocessing context ('spawn' or 'fork').
        scheduler: the address of a Dask distributed scheduler: run the episodes on its
            workers instead of local processes (:mod:`swarm_supervisor.cluster`).
        scheduler_timeout: seconds to wait for the scheduler to answer.
        bag: record each episode's bag (the node system's record) in its folder's ``bag/``;
            a kept episode without one is run again.
        videos: also render one video per cell of the design (its first seed's episode)
            into ``out_dir/videos/`` (implies ``bag``).
        batch_size: episodes stepped together in one worker (1: one at a time); the
            outputs are the same for any size.

    Returns:
        The tidy table as flat rows (one dict per episode and sample), columns
        :data:`TABLE_COLUMNS`.

    Raises:
        StudyError: a finished episode in ``out_dir`` was run with other parameters.
    """
    started, stamp = time.perf_counter(), time.strftime('%Y-%m-%dT%H:%M:%S')
    out = Path(out_dir)
    (out / EPISODES_DIR).mkdir(parents=True, exist_ok=True)
    study = config.study
    times = snapshot_times(study)
    specs = design(config)
    folders = {spec: out / EPISODES_DIR / spec.name for spec in specs}
    pending = []
    for spec in specs:
        episode = episode_config(config, spec)
        bag = bag or videos
        if outputs.episode_complete(folders[spec]) and (
                not bag or (folders[spec] / BAG_DIR / 'metadata.yaml').exists()):
            _check_kept(folders[spec], episode)
        else:
            pending.append((episode, times, str(folders[spec]), bag))
    write_ros_yaml(config, out / PARAMETERS_FILE)  # after the check: a refused run changes nothing
    if scheduler:
        from swarm_supervisor.cluster import run_on_cluster
        # As many batches as a few per worker would be; the cluster's size is not known here.
        jobs, ran = 0, run_on_cluster(make_batches(pending, batch_size, 1), scheduler,
                                      progress, scheduler_timeout)
    else:
        jobs = max(1, min(jobs or _available_cpus(), len(pending) or 1))
        ran = _run_pending(make_batches(pending, batch_size, jobs), jobs, progress,
                           start_method)
    rows = tidy_table([folders[spec] for spec in specs],
                      factors=study.factor_names).to_dict('records')
    write_table(rows, out / TABLE_FILE)
    rendered = render_videos(out, specs, progress) if videos else []
    _record_invocation(out / TIMING_FILE, {
        'started': stamp,
        'episodes': len(specs), 'ran': len(ran), 'kept': len(specs) - len(ran), 'jobs': jobs,
        'batch_size': batch_size,
        'scheduler': scheduler, 'videos': [str(path.relative_to(out)) for path in rendered],
        'wall_time_s': round(time.perf_counter() - started, 3),
        'cpu_time_s': round(sum(cpu for _, cpu in ran.values()), 3),
        'episode_wall_time_s': {Path(folder).name: round(wall, 3)
                                for folder, (wall, _) in sorted(ran.items())},
        'episode_cpu_time_s': {Path(folder).name: round(cpu, 3)
                               for folder, (_, cpu) in sorted(ran.items())},
    })
    return rows


def render_videos(out: Path, specs: Sequence[EpisodeSpec], progress: bool | None,
                  speedup: float = 100.0) -> list[Path]:
    """One MP4 per cell of the design, from its first seed's episode bag, into
    ``out/videos/<episode>.mp4`` (an existing one is kept)."""
    from swarm_supervisor.animate import animate  # video libraries only when asked

    first = {}
    for spec in specs:
        first.setdefault((spec.population, spec.speed, spec.levels), spec)
    paths = []
    for spec in tqdm(first.values(), desc='videos', unit='videos', file=sys.stderr,
                     disable=None if progress is None else not progress):
        path = out / VIDEOS_DIR / f'{spec.name}.mp4'
        if not path.exists():
            animate(out / EPISODES_DIR / spec.name, path, speedup=speedup)
        paths.append(path)
    return paths


def _record_invocation(path: Path, entry: dict[str, Any]) -> None:
    """Append one invocation (what ran, wall times) to study.json's history."""
    try:
        history = json.loads(path.read_text())['invocations']
    except (OSError, ValueError, KeyError, TypeError):
        history = []
    path.write_text(json.dumps({'invocations': history + [entry]}, indent=2) + '\n')


def read_invocations(out_dir: str | Path) -> list[dict[str, Any]]:
    """The history of ``run_study`` calls on a folder (empty if none was recorded)."""
    try:
        return json.loads((Path(out_dir) / TIMING_FILE).read_text())['invocations']
    except (OSError, ValueError, KeyError, TypeError):
        return []


def _available_cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def show_done(bar: tqdm, progress: bool | None, done: int, total: int, folder: str,
              wall: float) -> None:
    """Count a finished episode on the progress bar, or, when stderr is a log rather than a
    terminal (the bar is off by itself), print one line for it."""
    bar.update(1)
    bar.set_postfix_str(Path(folder).name, refresh=False)
    if bar.disable and progress is None:
        print(f'episode {done}/{total} done: {Path(folder).name} ({wall:.1f} s)',
              file=sys.stderr, flush=True)


def _run_pending(batches: list, jobs: int, progress: bool | None,
                 start_method: str) -> dict[str, tuple[float, float]]:
    """Run the batches of tasks (:func:`make_batches`) over a pool of ``jobs`` processes with
    progress bars.

    Returns:
        folder -> (wall seconds, CPU seconds) of each episode (its share of its batch's),
        writing included.
    """
    pending = [task for batch in batches for task in batch]
    if not pending:
        return {}
    context = multiprocessing.get_context(start_method)
    counter = context.Value('d', 0.0)
    total = sum(task[0].episode.duration for task in pending)
    ran: dict[str, tuple[float, float]] = {}
    pool = context.Pool(jobs, initializer=_init_worker, initargs=(counter,))
    bar_format = '{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} {unit} ' \
                 '[{elapsed}<{remaining}]'
    try:
        with tqdm(total=len(pending), desc='episodes', unit='episodes', position=0,
                  disable=None if progress is None else not progress, file=sys.stderr,
                  bar_format=bar_format) as episodes, \
             tqdm(total=total, desc='sim time', unit='sim s', position=1,
                  disable=None if progress is None else not progress, file=sys.stderr,
                  bar_format=bar_format) as seconds:
            results = pool.imap_unordered(_run_batch_and_write, batches, chunksize=1)
            while len(ran) < len(pending):
                try:
                    done = results.next(timeout=0.5)
                except multiprocessing.TimeoutError:
                    pass
                else:
                    for folder, wall, cpu in done:
                        ran[folder] = wall, cpu
                        show_done(episodes, progress, len(ran), len(pending), folder, wall)
                seconds.update(min(counter.value, total) - seconds.n)
        pool.close()
    except BaseException:  # Ctrl-C or a failed episode: stop every worker now
        pool.terminate()
        raise
    finally:
        pool.join()
    return ran


def find_episodes(paths: Iterable[str | Path]) -> list[Path]:
    """Every complete episode folder (metrics.csv + episode.json) at or under ``paths``."""
    found = set()
    for path in map(Path, paths):
        if not path.exists():
            raise StudyError(f'{path} does not exist')
        candidates = [path] if (path / outputs.EPISODE_FILE).exists() else []
        candidates += [p.parent for p in path.rglob(outputs.EPISODE_FILE)]
        found.update(p for p in candidates if outputs.episode_complete(p))
    return sorted(found)


def recorded_findings(record: dict[str, Any]) -> list[Finding]:
    """What an episode.json says its record lacks: the completeness findings of
    ``mona-swarm analyze``, or for a record written before those existed, what its
    ``complete``, ``cue_maps`` and ``online_metrics`` fields imply (embedded runs: none).

    Raises:
        ValueError: the ``completeness`` field is not a list of findings.
    """
    if 'completeness' in record:
        if not isinstance(record['completeness'], list):
            raise ValueError(f'completeness is not a list: {record["completeness"]!r}')
        return [Finding.from_dict(item) for item in record['completeness']]
    findings = []
    if record.get('complete') is False:
        findings.append(Finding('samples', outputs.EPISODE_FILE,
                                f'the bag covers {record.get("sim_time_covered")} s of the '
                                f'{record.get("duration")} s episode'))
    for check in ('cue_maps', 'online_metrics'):
        worst = (record.get(check) or {}).get('max_abs_diff')
        if isinstance(worst, (int, float)) and worst != 0:
            findings.append(Finding(check, outputs.EPISODE_FILE,
                                    f'{check}.max_abs_diff is {worst}, not 0'))
    return findings


def episode_findings(folder: Path) -> list[Finding]:
    """Is an episode folder's record complete? Its recorded findings
    (:func:`recorded_findings`) plus the ``samples`` check of its metrics.csv (the samples
    must run from t = 0 to the duration without a gap), without repeats."""
    try:
        record = json.loads((folder / outputs.EPISODE_FILE).read_text())
        parameters = record.get('parameters', {})
        duration = float(record.get('duration', parameters['episode']['duration']))
        period = float(parameters['metrics']['sample_period'])
        times = outputs.read_metrics_csv(folder / outputs.METRICS_FILE)['t']
        checked = check_rows([{'t': t} for t in times], duration, period, outputs.METRICS_FILE)
        findings = recorded_findings(record)
    except (OSError, ValueError, TypeError, KeyError, AttributeError) as error:
        raise StudyError(f'{folder}: cannot check that its record is complete ({error})') \
            from None
    for finding in checked:
        if not any((f.check, f.detail) == (finding.check, finding.detail) for f in findings):
            findings.append(finding)
    return findings


def incomplete_episodes(folders: Iterable[Path]) -> dict[Path, list[Finding]]:
    """The folders whose record is incomplete, with what each lacks (:func:`episode_findings`).

    Raises:
        StudyError: a folder's episode.json or metrics.csv cannot be read.
    """
    found = {Path(folder): episode_findings(Path(folder)) for folder in folders}
    return {folder: findings for folder, findings in found.items() if findings}


def _read_record(folder: Path) -> dict[str, Any]:
    try:
        return json.loads((folder / outputs.EPISODE_FILE).read_text())
    except (OSError, ValueError) as error:
        raise StudyError(f'{folder / outputs.EPISODE_FILE}: {error}') from None


def _parameter(record: dict[str, Any], key: str) -> Any:
    section, _, name = key.partition('.')
    return record.get('parameters', {}).get(section, {}).get(name)


def episode_key(folder: Path, factors: Sequence[str] = ()) -> dict[str, Any]:
    """The factor levels of an episode folder, from its episode.json (either runner's):
    population, speed, seed and the values of the extra ``factors`` (dotted keys)."""
    record = _read_record(folder)
    parameters = record.get('parameters', {})
    try:
        key = {
            'population': int(record.get('population',
                                         parameters.get('episode', {}).get('population'))),
            'speed': float(record.get('speed', parameters.get('controller', {}).get('speed'))),
            'seed': int(record.get('seed', parameters.get('episode', {}).get('seed'))),
        }
    except (ValueError, TypeError, AttributeError) as error:
        raise StudyError(f'{folder / outputs.EPISODE_FILE}: cannot read population, speed '
                         f'and seed ({error})') from None
    for name in factors:
        value = _parameter(record, name)
        if value is None:
            raise StudyError(f'{folder / outputs.EPISODE_FILE} has no parameter {name}')
        key[name] = value
    return key


def varying_parameters(folders: Sequence[Path]) -> list[str]:
    """The parameters (dotted keys) whose values differ between the episodes, other than
    those the design sets itself: the extra factors of a set of episodes whose study is not
    known (e.g. ``study --from-episodes``), in the schema's order."""
    records = [_read_record(Path(folder)) for folder in folders]
    names = []
    for section, fields in SwarmConfig().to_dict().items():
        if section == 'study':
            continue
        for name in fields:
            key = f'{section}.{name}'
            if key in DESIGN_KEYS:
                continue
            values = {json.dumps(_parameter(record, key), sort_keys=True) for record in records}
            if len(values) > 1:
                names.append(key)
    return names


def tidy_table(folders: Sequence[Path], factors: Sequence[str] | None = None) -> pd.DataFrame:
    """All episodes as one table, sorted by episode and t: columns population, speed, seed,
    the extra ``factors`` (dotted keys; default: the parameters that vary between the
    folders, :func:`varying_parameters`), then t and the metrics (with several sources, the
    per-source metrics after them).

    Raises:
        StudyError: a folder's files are unreadable, or two folders hold the same episode.
    """
    folders = [Path(folder) for folder in folders]
    factors = list(varying_parameters(folders) if factors is None else factors)
    frames, seen, shared = [], {}, []
    for folder in folders:
        key = episode_key(folder, factors)
        identity = json.dumps(list(key.values()))
        if identity in seen:
            raise StudyError(f'{seen[identity]} and {folder} are the same episode (N, speed, '
                             'seed' + ''.join(f', {name}' for name in factors) +
                             '); analyse them separately')
        seen[identity] = folder
        try:
            metrics = pd.read_csv(folder / outputs.METRICS_FILE)
        except (OSError, ValueError) as error:
            raise StudyError(f'{folder / outputs.METRICS_FILE}: {error}') from None
        missing = [c for c in COLUMNS if c not in metrics.columns]
        if missing:
            raise StudyError(f'{folder / outputs.METRICS_FILE} lacks columns {missing}')
        per_source = [c for c in metrics.columns if is_source_column(c)]
        shared = per_source if not frames else [c for c in shared if c in per_source]
        frames.append(metrics[list(COLUMNS) + per_source].assign(**key))
    if not frames:
        raise StudyError('no episodes to tabulate')
    # Several sources: their columns (metrics.source_columns) follow, if every episode has them.
    columns = list(KEYS) + factors + list(COLUMNS) + shared
    table = pd.concat(frames, ignore_index=True)[columns]
    return table.sort_values(list(KEYS) + factors + ['t'], kind='stable', ignore_index=True)


def design_factors(table: pd.DataFrame) -> list[str]:
    """The factors a design declares beyond population, speed and seed: the table's columns
    that are not :data:`TABLE_COLUMNS`, named by their dotted parameter key (e.g.
    ``mona.ir_range``), in table order."""
    return [column for column in table.columns
            if column not in TABLE_COLUMNS and not is_source_column(column)]


def write_table(rows: list[dict[str, float]] | pd.DataFrame, path: str | Path) -> None:
    """Write the tidy table as CSV (floats at full precision)."""
    frame = rows if isinstance(rows, pd.DataFrame) else \
        pd.DataFrame(rows, columns=list(rows[0]) if rows else TABLE_COLUMNS)
    frame.to_csv(path, index=False)


def read_table(path: str | Path) -> pd.DataFrame:
    """Read ``all_metrics.csv`` back (checks its columns)."""
    table = pd.read_csv(path)
    missing = [c for c in TABLE_COLUMNS if c not in table.columns]
    if missing:
        raise StudyError(f'{path} lacks columns {missing}')
    return table

