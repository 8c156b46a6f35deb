"""Writing one episode's outputs: metrics.csv, episode.json, snapshots.npz and a PNG.

episode.json is written last, through a temporary file, so its presence marks a complete
episode (the study resumes on that).
"""

from __future__ import annotations

import csv
import json
import os
import platform
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from swarm_metrics.metrics import COLUMNS
from swarm_supervisor import __version__
from swarm_supervisor.engine.runner import EpisodeResult

METRICS_FILE = 'metrics.csv'
EPISODE_FILE = 'episode.json'
SNAPSHOTS_FILE = 'snapshots.npz'
FINAL_PNG = 'final_cue_map.png'


def write_metrics_csv(rows: list[dict[str, float]], path: str | Path) -> None:
    """One row per sample: the columns :data:`~swarm_metrics.metrics.COLUMNS`, then the
    per-source ones an episode with several sources adds (``metrics.columns``)."""
    names = list(rows[0]) if rows else list(COLUMNS)
    with open(path, 'w', newline='') as handle:
        writer = csv.DictWriter(handle, fieldnames=names)
        writer.writeheader()
        for row in rows:
            writer.writerow({key: repr(float(row[key])) for key in names})


def read_metrics_csv(path: str | Path) -> dict[str, np.ndarray]:
    """metrics.csv as a column -> float array mapping (every column it has)."""
    with open(path, newline='') as handle:
        reader = csv.DictReader(handle)
        rows = list(reader)
        names = reader.fieldnames or list(COLUMNS)
    return {key: np.array([float(row[key]) for row in rows]) for key in names}


def episode_record(result: EpisodeResult, runner: str = 'embedded') -> dict:
    """The provenance of an episode: seed, every parameter, the plug-ins, timing, software
    version."""
    config = result.config
    return {
        'seed': config.episode.seed,
        'population': config.episode.population,
        'speed': config.controller.speed,
        'duration': config.episode.duration,
        'runner': runner,
        'steps': result.steps,
        'encounters': result.encounters,
        'wall_time_s': round(result.wall_time, 3),
        'real_time_factor': round(result.real_time_factor, 1),
        'final_mean_cue': result.metrics[-1]['mean_cue'],
        'final_mean_cue_fraction': result.metrics[-1]['mean_cue_fraction'],
        'software': {'mona_swarm': __version__, 'python': platform.python_version(),
                     'numpy': np.__version__},
        'parameters': config.to_dict(),
        # The code beyond the package's it ran: each plug-in's file and SHA-256.
        'plugins': config.plugin_records(),
    }


def write_episode(result: EpisodeResult, out_dir: str | Path, *, runner: str = 'embedded',
                  extra: dict[str, Any] | None = None, omit: Iterable[str] = (),
                  picture: bool = True) -> Path:
    """Write every output of one episode into ``out_dir`` (created if needed).

    Args:
        result: the episode.
        out_dir: the episode folder.
        runner: recorded as episode.json's ``runner``.
        extra: more episode.json fields (e.g. what a bag tells), added after the others.
        omit: episode.json fields to leave out (e.g. timing a bag cannot give).
        picture: also draw the final cue map (FINAL_PNG). Off for episodes that are only
            scored and deleted (a calibration's screening): matplotlib takes longer to draw
            it than a short episode takes to run.

    Returns:
        ``out_dir``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_metrics_csv(result.metrics, out / METRICS_FILE)
    times = sorted(result.snapshots)
    np.savez_compressed(
        out / SNAPSHOTS_FILE, times=np.array(times, dtype=np.float64),
        cue=np.array([result.snapshots[t][0] for t in times], dtype=np.float32).reshape(
            len(times), *result.final_cue.shape),
        poses=np.array([result.snapshots[t][1] for t in times]).reshape(
            len(times), len(result.final_poses), 3),
        final_cue=result.final_cue, final_poses=result.final_poses,
        initial_poses=result.initial_poses)
    if picture:
        _save_final_picture(out / FINAL_PNG, result)
    record = episode_record(result, runner)
    for key in omit:
        record.pop(key, None)
    record.update(extra or {})
    temporary = out / (EPISODE_FILE + '.tmp')
    temporary.write_text(json.dumps(record, indent=2) + '\n')
    os.replace(temporary, out / EPISODE_FILE)
    return out


def _save_final_picture(path: Path, result: EpisodeResult) -> None:
    """The final cue map with the robots, titled with the episode's cell and seed."""
    from swarm_supervisor.outputs.pictures import save_cue_map  # matplotlib: only to draw

    config = result.config
    save_cue_map(path, result.final_cue, result.final_poses,
                 config.world.arena_side, config.mona.body_radius,
                 obstacles=config.world.arena().obstacles,
                 title=f'N = {config.episode.population}, v = {config.controller.speed * 100:g}'
                       f' cm/s, seed {config.episode.seed}, t = {result.metrics[-1]["t"]:g} s')


def episode_complete(out_dir: str | Path) -> bool:
    """True when ``out_dir`` holds a finished episode (episode.json exists and parses)."""
    try:
        record = json.loads((Path(out_dir) / EPISODE_FILE).read_text())
    except (OSError, ValueError):
        return False
    return isinstance(record, dict) and (Path(out_dir) / METRICS_FILE).exists()
