"""Running a study: every missing episode of the design, kept ones checked, one table.

Each episode of the design (:mod:`~swarm_supervisor.study.specs`) gets a folder
``DIR/episodes/<name>/`` written by :func:`swarm_supervisor.outputs.write_episode`; its
episode.json is written last, so a folder without it is half-written and is run again, while
a complete one is kept (after checking it was run with the same parameters). The episodes
run in batches on local processes (:mod:`~swarm_supervisor.study.local`) or a Dask cluster
(:mod:`~swarm_supervisor.study.cluster`), and become ``all_metrics.csv``
(:mod:`~swarm_supervisor.study.table`).
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from tqdm import tqdm

from mona_controller.mappings import leaves
from swarm_supervisor import outputs
from swarm_supervisor.config import SwarmConfig, current_keys, mapping_value, write_ros_yaml
from swarm_supervisor.study import DEFAULT_BATCH_SIZE
from swarm_supervisor.study.errors import StudyError
from swarm_supervisor.study.folder import (
    EPISODES_DIR,
    FIX,
    PARAMETERS_FILE,
    TIMING_FILE,
    claim_study_folder,
)
from swarm_supervisor.study.interrupt import Interrupted, StopRequest, raise_if_stopped
from swarm_supervisor.study.local import available_cpus, run_local
from swarm_supervisor.study.specs import EpisodeSpec, design, episode_config, snapshot_times
from swarm_supervisor.study.table import TABLE_FILE, tidy_table, write_table
from swarm_supervisor.study.tasks import BAG_DIR, EpisodeTask, make_batches
from swarm_supervisor.study.validate import check_design
from swarm_supervisor.study.workers import START_METHOD

VIDEOS_DIR = 'videos'  #: one video per design cell (``study --videos``)


def _expected_parameters(config: SwarmConfig) -> dict[str, Any]:
    """The parameters as episode.json stores them (after a JSON round trip)."""
    return json.loads(json.dumps(config.to_dict()))


def _check_kept(folder: Path, config: SwarmConfig) -> None:
    """Refuse to mix a finished episode run with other parameters or other plug-in code into
    this study. A parameter the episode's record lacks (one added to the schema since) counts
    as its default: that is what the episode ran; one that moved since is read at its new
    key."""
    record = json.loads((folder / outputs.EPISODE_FILE).read_text())
    ran = {(plugin.get('path'), plugin.get('sha256')) for plugin in record.get('plugins', [])}
    for plugin in config.plugins:
        if (plugin.path, plugin.sha256) not in ran:
            raise StudyError(f'{folder} was run without the plug-in {plugin.path} as it is now '
                             f'(SHA-256 {plugin.sha256[:12]}...): --out holds a study that ran '
                             f'other code; {FIX}')
    stored = current_keys(record.get('parameters', {}))
    expected = _expected_parameters(config)
    defaults = _expected_parameters(SwarmConfig())
    for key in leaves(config):
        if key.startswith('study.'):  # the design around the episode does not change it
            continue
        value = mapping_value(expected, key)
        if mapping_value(stored, key, mapping_value(defaults, key)) != value:
            raise StudyError(
                f'{folder} was run with {key} = {mapping_value(stored, key)!r}, this study '
                f'needs {value!r}: --out holds a study of another design; {FIX}')


def plan(config: SwarmConfig, out_dir: str | Path, *, bag: bool = False,
         picture: bool = True
         ) -> tuple[list[EpisodeSpec], dict[EpisodeSpec, Path], list[EpisodeTask]]:
    """The episodes of ``config.study`` in ``out_dir``: every spec, its folder, and the tasks of
    those not yet complete there (``bag``: also those without their bag; ``picture``: also
    those without their final cue map, which the tasks draw only with it).

    Episodes already complete are kept, after checking they were run with the same parameters.
    Nothing is written (the workers create the folders).

    Raises:
        StudyError: a finished episode in ``out_dir`` was run with other parameters.
    """
    out = Path(out_dir)
    times = snapshot_times(config.study)
    specs = design(config)
    folders = {spec: out / EPISODES_DIR / spec.name for spec in specs}
    pending: list[EpisodeTask] = []
    for spec in specs:
        episode = episode_config(config, spec)
        if outputs.episode_complete(folders[spec]) and (
                not bag or (folders[spec] / BAG_DIR / 'metadata.yaml').exists()) and (
                not picture or (folders[spec] / outputs.FINAL_PNG).exists()):
            _check_kept(folders[spec], episode)
        else:
            pending.append(EpisodeTask(episode, times, str(folders[spec]), bag, picture))
    return specs, folders, pending


def run_study(config: SwarmConfig, out_dir: str | Path, *, jobs: int | None = None,
              progress: bool | None = None, start_method: str = START_METHOD,
              scheduler: str | None = None, scheduler_timeout: float = 30.0,
              bag: bool = False, videos: bool = False,
              batch_size: int = DEFAULT_BATCH_SIZE,
              overwrite: bool = False) -> list[dict[str, float]]:
    """Run every missing episode of ``config.study`` into ``out_dir`` and tabulate them all.

    Episodes already complete in ``out_dir/episodes`` are kept (after checking they were run
    with the same parameters); the others run in batches of at most ``batch_size`` episodes
    stepped together (the batched engine), costliest first, over ``jobs`` worker
    processes; each episode is written as soon as it is done.
    Writes ``parameters.yaml`` (the configuration), ``study.json`` (what ran with which
    plug-ins, how it ended, wall times) and ``all_metrics.csv``. The design and the folder
    are checked first (:func:`~swarm_supervisor.study.validate.check_design`,
    :func:`~swarm_supervisor.study.folder.claim_study_folder`): a refusal writes nothing.
    Ctrl-C or SIGTERM stops at once, cutting the running batches
    (:mod:`~swarm_supervisor.study.interrupt`); finished episodes stay on disk and the next
    call resumes from them.

    Args:
        jobs: worker processes (default: the CPUs this process may use).
        progress: show progress bars on stderr (None: only on a terminal).
        start_method: the local pool's multiprocessing start method ('forkserver', the
            default: :mod:`swarm_supervisor.study.workers`; 'spawn' or 'fork').
        scheduler: the address of a Dask distributed scheduler: run the episodes on its
            workers instead of local processes (:mod:`swarm_supervisor.study.cluster`).
        scheduler_timeout: seconds to wait for the scheduler to answer.
        bag: record each episode's bag (the node system's record) in its folder's ``bag/``;
            a kept episode without one is run again.
        videos: also render one video per cell of the design (its first seed's episode)
            into ``out_dir/videos/`` (implies ``bag``).
        batch_size: episodes stepped together in one worker (1: one at a time); the
            outputs are the same for any size.
        overwrite: delete whatever record ``out_dir`` holds first, and start over.

    Returns:
        The tidy table as flat rows (one dict per episode and sample), columns
        :data:`~swarm_supervisor.study.table.TABLE_COLUMNS`.

    Raises:
        StudyError: a cell of the design cannot run, or ``out_dir`` holds a study of another
            design or a record of another kind (and not ``overwrite``).
        Interrupted: stopped by a signal; its ``kept`` episodes of ``total`` are complete.
    """
    started, stamp = time.perf_counter(), time.strftime('%Y-%m-%dT%H:%M:%S')
    out = Path(out_dir)
    outputs.check_place(out)  # a file, a place that cannot take it, another writer
    if scheduler:  # at once: not an address (whether it answers is asked below)
        from swarm_supervisor.study.cluster import check_address
        check_address(scheduler)
    check_design(config)  # before a worker starts or a byte is written
    if not overwrite:  # read only: a refusal leaves the folder as it was
        specs, folders, pending = plan(config, out, bag=bag or videos)
        claim_study_folder(config, out)
    client = None
    if scheduler and (overwrite or pending):  # an unreachable one is refused before --out
        from swarm_supervisor.study.cluster import connect
        client = connect(scheduler, scheduler_timeout)
    outputs.hold(out)  # created, and locked while the study runs
    if overwrite:
        claim_study_folder(config, out, overwrite=True)
        specs, folders, pending = plan(config, out, bag=bag or videos)
    (out / EPISODES_DIR).mkdir(parents=True, exist_ok=True)
    write_ros_yaml(config, out / PARAMETERS_FILE)  # after the checks: a refusal changes nothing
    entry: dict[str, Any] = {'started': stamp, 'episodes': len(specs),
                             'plugins': config.plugin_records()}

    def record(ran: dict[str, tuple[float, float]], jobs: int, outcome: str,
               rendered: Sequence[Path] = ()) -> int:
        complete = sum(outputs.episode_complete(folder) for folder in folders.values())
        _record_invocation(out / TIMING_FILE, {
            **entry, 'ended': time.strftime('%Y-%m-%dT%H:%M:%S'), 'outcome': outcome,
            'ran': len(ran), 'kept': len(specs) - len(pending), 'complete': complete,
            'jobs': jobs, 'batch_size': batch_size, 'scheduler': scheduler,
            'videos': [str(path.relative_to(out)) for path in rendered],
            'wall_time_s': round(time.perf_counter() - started, 3),
            'cpu_time_s': round(sum(cpu for _, cpu in ran.values()), 3),
            'episode_wall_time_s': {Path(folder).name: round(wall, 3)
                                    for folder, (wall, _) in sorted(ran.items())},
            'episode_cpu_time_s': {Path(folder).name: round(cpu, 3)
                                   for folder, (_, cpu) in sorted(ran.items())},
        })
        return complete

    # The handlers stay while the stop is recorded: a second Ctrl-C cannot cut that short.
    with StopRequest():
        try:
            jobs, ran = run_tasks(pending, jobs=jobs, progress=progress,
                                  start_method=start_method, scheduler=scheduler,
                                  scheduler_timeout=scheduler_timeout, batch_size=batch_size,
                                  client=client)
            # A signal whose exception was lost while the pool's results were awaited: the
            # episodes ran, but the stop was asked for (docs/study.md).
            raise_if_stopped(ran)
        except Interrupted as stopped:
            workers = 0 if scheduler else max(1, min(jobs or available_cpus(), len(pending)))
            stopped.kept = record(stopped.ran, workers, f'interrupted by {stopped.name}')
            stopped.total, stopped.folder = len(specs), str(out)
            raise
    rows = tidy_table([folders[spec] for spec in specs],
                      factors=config.study.factor_names).to_dict('records')
    write_table(rows, out / TABLE_FILE)
    rendered = render_videos(out, specs, progress) if videos else []
    record(ran, jobs, 'finished', rendered)
    return rows


def run_tasks(pending: Sequence[EpisodeTask], *, jobs: int | None = None,
              progress: bool | None = None, start_method: str = START_METHOD,
              scheduler: str | None = None, scheduler_timeout: float = 30.0,
              batch_size: int = DEFAULT_BATCH_SIZE, client: Any = None
              ) -> tuple[int, dict[str, tuple[float, float]]]:
    """Run the tasks in batches on local processes or, with ``scheduler``, a Dask cluster
    (arguments as :func:`run_study`'s; ``client``: one connected to it already).

    Returns:
        (the worker processes used, 0 on a cluster; folder -> (wall s, CPU s) of each episode).
    """
    if scheduler:
        from swarm_supervisor.study.cluster import run_on_cluster
        # As many batches as a few per worker would be; the cluster's size is not known here.
        return 0, run_on_cluster(make_batches(pending, batch_size, 1), scheduler, progress,
                                 scheduler_timeout, client=client)
    jobs = max(1, min(jobs or available_cpus(), len(pending) or 1))
    return jobs, run_local(make_batches(pending, batch_size, jobs), jobs, progress, start_method)


def render_videos(out: Path, specs: Sequence[EpisodeSpec], progress: bool | None,
                  speedup: float = 100.0) -> list[Path]:
    """One MP4 per cell of the design, from its first seed's episode bag, into
    ``out/videos/<episode>.mp4`` (an existing one is kept)."""
    from swarm_supervisor.media.video import animate  # video libraries only when asked

    first: dict[tuple[Any, ...], Any] = {}
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
