"""Episode folders as one table: finding them, checking their records, tabulating them.

The episodes of a study (or any folders holding metrics.csv + episode.json, e.g. from ROS
bags) become one tidy table, ``all_metrics.csv``, with one row per episode and sample::

    population, speed, seed, [factors...,] t, mean_cue, mean_cue_fraction, ratio_near_source,
    coherency, [added metrics...,] [per-source metrics...]

where each extra factor is a column named by its dotted key (speed in m/s), and every metric
the episodes' metrics.csv has beyond the paper's (a plug-in's, docs/extending.md) follows the
paper's four.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from mona_controller import plugins
from mona_controller.mappings import leaves
from mona_controller.plugins import Plugin
from swarm_metrics.bags.checks import Finding, check_rows
from swarm_metrics.metrics import COLUMNS, is_source_column
from swarm_supervisor import outputs
from swarm_supervisor.config import DESIGN_KEYS, SwarmConfig, current_keys, mapping_value
from swarm_supervisor.study.errors import StudyError

TABLE_FILE = 'all_metrics.csv'
KEYS = ('population', 'speed', 'seed')
TABLE_COLUMNS = KEYS + COLUMNS


def find_episodes(paths: Iterable[str | Path]) -> list[Path]:
    """Every complete episode folder (metrics.csv + episode.json) at or under ``paths``, but
    a study's episodes still being written (``.<name>.partial``, :mod:`.tasks`)."""
    found: set[Path] = set()
    for path in map(Path, paths):
        if not path.exists():
            raise StudyError(f'{path} does not exist')
        candidates = [path] if (path / outputs.EPISODE_FILE).exists() else []
        candidates += [p.parent for p in path.rglob(outputs.EPISODE_FILE)]
        found.update(p for p in candidates if outputs.episode_complete(p)
                     and not p.name.endswith('.partial'))
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


def recorded_plugins(folders: Iterable[Path]) -> list[Plugin]:
    """The plug-ins the episodes in ``folders`` recorded (each once, in first-seen order).

    Raises:
        StudyError: an episode.json is unreadable.
        PluginError: its plug-in records are malformed.
    """
    found: dict[tuple[str, str], Plugin] = {}
    for folder in folders:
        for plugin in plugins.from_records(_read_record(Path(folder)).get('plugins'),
                                           f'{Path(folder) / outputs.EPISODE_FILE}: plugins'):
            found.setdefault((plugin.module, plugin.sha256), plugin)
    return list(found.values())


def _read_record(folder: Path) -> dict[str, Any]:
    """An episode.json, its parameters under their current keys."""
    try:
        record = json.loads((folder / outputs.EPISODE_FILE).read_text())
    except (OSError, ValueError) as error:
        raise StudyError(f'{folder / outputs.EPISODE_FILE}: {error}') from None
    if isinstance(record, dict) and isinstance(record.get('parameters'), dict):
        record['parameters'] = current_keys(record['parameters'])
    return record


def _parameter(record: dict[str, Any], key: str) -> Any:
    return mapping_value(record.get('parameters', {}), key)


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
    for key in leaves(SwarmConfig()):
        if key.startswith('study.') or key in DESIGN_KEYS:
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
    frames: list[pd.DataFrame] = []
    seen: dict[str, Path] = {}
    shared: list[Any] = []
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
        extra = added_metrics(metrics.columns) + [c for c in metrics.columns
                                                  if is_source_column(c)]
        shared = extra if not frames else [c for c in shared if c in extra]
        frames.append(metrics[list(COLUMNS) + extra].assign(**key))
    if not frames:
        raise StudyError('no episodes to tabulate')
    # Added metrics, then with several sources their columns (metrics.source_columns), follow
    # if every episode has them.
    columns = list(KEYS) + factors + list(COLUMNS) + shared
    table = pd.concat(frames, ignore_index=True)[columns]
    return table.sort_values(list(KEYS) + factors + ['t'], kind='stable', ignore_index=True)


def added_metrics(columns: Iterable[str]) -> list[str]:
    """The metrics beyond the paper's among metrics.csv or table ``columns`` (in their
    order): the columns that are no key, factor (a dotted key), paper's metric or
    per-source metric."""
    return [column for column in columns if column not in TABLE_COLUMNS and '.' not in column
            and not is_source_column(column)]


def design_factors(table: pd.DataFrame) -> list[str]:
    """The factors a design declares beyond population, speed and seed: the table's columns
    named by a dotted parameter key (e.g. ``mona.ir_range``; a metric's name has no dot), in
    table order."""
    return [column for column in table.columns
            if column not in TABLE_COLUMNS and '.' in column]


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
