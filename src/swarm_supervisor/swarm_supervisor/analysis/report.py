"""From episode folders to the study's results: figures, ANOVA tables and report.md.

:func:`analyse` is the one path from episodes to results, whichever runner produced them
(the embedded study, or ``mona-swarm analyze`` on ROS bags): it reads each folder's
metrics.csv and episode.json, writes ``all_metrics.csv``, figures 3-6, ``anova_cue.csv`` and
``anova_coherency.csv``, and a ``report.md`` whose reading of the results is computed from
the data.
"""

from __future__ import annotations

import dataclasses
import json
import platform
import subprocess
import time
from collections.abc import Mapping, Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from mona_controller.mappings import from_mapping
from mona_controller.schema import ParameterError
from swarm_metrics.bags.checks import Finding
from swarm_metrics.metrics import METRICS, source_names
from swarm_supervisor import __version__, outputs, study
from swarm_supervisor.analysis import beyond_figures, checks, figures, profile, sensitivity
from swarm_supervisor.analysis import claims as claim_checks
from swarm_supervisor.analysis.reading import cleaning_summary, reading, variant_table
from swarm_supervisor.analysis.report_tables import (
    fit_anovas,
    markdown_table,
    tables_section,
    timing_section,
    unfitted_reading,
    write_anovas,
)
from swarm_world.params import WorldParams

REPORT_FILE = 'report.md'
#: The paper's claims no model we have tried reaches: every shipped profile, every trial of
#: the calibration and every trial of the existence search fails them (docs/reproduction.md).
UNREACHED = ('fig6-sparse-unchanged',)
#: The claims the existence search reached only with swarms that neither gather nor clean
#: (where they hold, the cue is not halved by 1500 s and the ratio near the source does not rise).
ONLY_WITHOUT_CLEANING = ('fig5-sparse-unchanged', 'table2-factor-order')
#: The reproduction report, in the source tree.
REPRODUCTION = 'docs/reproduction.md'
DEPENDENCIES = ('numpy', 'pymunk', 'pandas', 'statsmodels', 'matplotlib')


@dataclasses.dataclass
class Figure:
    """One figure of the report: its file (None when skipped) and a note."""

    title: str
    file: str | None
    note: str = ''


def _records(folders: Sequence[Path]) -> list[dict[str, Any]]:
    return [json.loads((folder / outputs.EPISODE_FILE).read_text()) for folder in folders]


def analyse(out_dir: str | Path, folders: Sequence[Path], *,
            table: pd.DataFrame | None = None, sources: Sequence[str] = (),
            parameters_file: str | None = None,
            incomplete: Mapping[Path, Sequence[Finding]] | None = None,
            claims_files: Sequence[str | Path] = ()) -> Path:
    """Write every result of a study of the episodes in ``folders`` into ``out_dir``.

    Args:
        table: the tidy table of ``folders`` if already built (else read from them).
        sources: where the episodes came from, for the report (default: ``out_dir``).
        parameters_file: the parameter file saved in ``out_dir`` that produced them, if any.
        incomplete: the folders whose record is incomplete and what each lacks
            (:func:`swarm_supervisor.study.table.incomplete_episodes`; default: what their
            episode.json records), listed in the report.
        claims_files: claims files checked beside the paper's claims
            (:func:`swarm_supervisor.analysis.claims.all_claims`).

    Returns:
        The path of report.md.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    folders = [Path(folder) for folder in folders]
    if table is None:
        table = study.tidy_table(folders)
        study.write_table(table, out / study.TABLE_FILE)
    records = _records(folders)
    if incomplete is None:
        incomplete = {folder: findings for folder, record in zip(folders, records)
                      if (findings := study.recorded_findings(record))}
    drawn = make_figures(out, table, folders, records)
    tables = fit_anovas(table)  # or, per response, why it cannot be fitted
    write_anovas(out, tables)
    variants = variant_table(table)
    claims = claim_checks.all_claims(claims_files)
    compared = checks.evaluate_levels(table, claims)
    matrix = sensitivity.write_sensitivity(out, table, claims)
    path = out / REPORT_FILE
    path.write_text(render(out, table, folders, records, drawn, tables, sources=sources,
                           parameters_file=parameters_file, incomplete=incomplete,
                           compared=compared, variants=variants, matrix=matrix))
    return path


def make_figures(out: Path, table: pd.DataFrame, folders: Sequence[Path],
                 records: Sequence[dict[str, Any]]) -> list[Figure]:
    """Figures 3-6 into ``out`` (and the per-source figure when the episodes have several
    sources, and one per metric beyond the paper's that the table has,
    :func:`~swarm_supervisor.analysis.figures.extra_metrics`); fig. 3 is skipped (with a note)
    when no episode kept maps."""
    initial = table['mean_cue'] / table['mean_cue_fraction']
    initial_mean = float(np.nanmedian(initial)) if initial.notna().any() else 0.0
    radius = records[0].get('parameters', {}).get('metrics', {}).get('source_radius', 0.7)
    drawn = [fig3(out, folders, records)]
    if drawn[0].file is None:  # never leave an earlier run's fig. 3 beside these results
        (out / figures.FIG3).unlink(missing_ok=True)
    drawn.append(Figure('Fig. 4: mean cue vs time', figures.FIG4,
                        figures.fig4_mean_cue(table, out / figures.FIG4,
                                              initial_mean=initial_mean)))
    drawn.append(Figure('Fig. 5: ratio of robots near the source', figures.FIG5,
                        figures.fig5_ratio_near_source(table, out / figures.FIG5,
                                                       source_radius=radius)))
    drawn.append(Figure('Fig. 6: coherency', figures.FIG6,
                        figures.fig6_coherency(table, out / figures.FIG6)))
    if source_names(list(table.columns)):
        drawn.append(Figure('Cue near each source', beyond_figures.FIG_SOURCES,
                            beyond_figures.fig_sources(table, out / beyond_figures.FIG_SOURCES)))
    else:  # never leave an earlier design's figure beside these results
        (out / beyond_figures.FIG_SOURCES).unlink(missing_ok=True)
    extra = beyond_figures.extra_metrics(table)
    for name in extra:
        file = beyond_figures.FIG_METRIC.format(name)
        drawn.append(Figure(f'{name}: {METRICS[name].doc}', file,
                            beyond_figures.fig_metric(table, out / file, name)))
    for stale in out.glob(beyond_figures.FIG_METRIC.format('*')):  # a metric no longer drawn
        if stale.name not in {beyond_figures.FIG_METRIC.format(name) for name in extra}:
            stale.unlink()
    return drawn


def fig3(out: Path, folders: Sequence[Path], records: Sequence[dict[str, Any]]) -> Figure:
    """Fig. 3 from the episode nearest N = 30 at 8 cm/s (first seed) that kept cue maps."""
    title = 'Fig. 3: cue maps'
    mapped = [(folder, record) for folder, record in zip(folders, records)
              if (folder / outputs.SNAPSHOTS_FILE).exists()]
    if not mapped:
        return Figure(title, None, 'skipped: no episode folder holds snapshots.npz (episodes '
                      'analysed from ROS bags keep no cue maps); run the embedded study for '
                      'fig. 3')
    keys = [study.episode_key(folder) for folder, _ in mapped]
    speed = figures.choose_speed([key['speed'] for key in keys])
    population = figures.nearest([k['population'] for k in keys if k['speed'] == speed],
                                 figures.FIG3_POPULATION)
    seed, folder, record = min((k['seed'], f, r) for k, (f, r) in zip(keys, mapped)
                               if k['speed'] == speed and k['population'] == population)
    notes = []
    if population != figures.FIG3_POPULATION or not np.isclose(speed, figures.PAPER_SPEED):
        notes.append("nearest to the paper's N = 30, 8 cm/s in this design")
    parameters = record.get('parameters', {})
    with np.load(folder / outputs.SNAPSHOTS_FILE) as archive:
        snapshots = {name: archive[name] for name in ('times', 'cue', 'poses')}
    try:
        note = figures.fig3_cue_maps(
            snapshots, out / figures.FIG3, population=population, speed=speed, seed=seed,
            arena_side=parameters['world']['arena_side'],
            body_radius=parameters['mona']['body_radius'],
            peak=parameters['world']['cue_peak'],
            duration=float(record.get('duration', parameters['episode']['duration'])),
            substitute='; '.join(notes), obstacles=_obstacles(parameters))
    except figures.FigureSkipped as reason:
        return Figure(title, None, f'skipped: {reason} ({folder.name})')
    return Figure(title, figures.FIG3, f'episode {folder.name}' + (f'; {note}' if note else ''))


def _obstacles(parameters: Mapping[str, Any]) -> tuple:
    """The arena's obstacles from an episode's recorded parameters (none if unreadable)."""
    try:
        return from_mapping(WorldParams, parameters.get('world', {}), 'world.').arena().obstacles
    except (ParameterError, TypeError, AttributeError):
        return ()


def compared_section(compared: Sequence[tuple[dict[str, Any],
                                              Sequence[claim_checks.ClaimResult]]],
                     labels: Sequence[str] = ()) -> list[str]:
    """'Compared with the paper': each claim, the paper's words, ours, and whether it holds
    (one table per combination of the design factors' levels, headed by ``labels`` if given,
    e.g. the figures' panel labels)."""
    lines = ['## Compared with the paper', '',
             "*Each finding of the paper's results section (and any claims added with "
             '`--claims`), checked on the table above by the check its claims file names '
             '(`swarm_supervisor/paper_claims.yaml`); medians over seeds.*', '',
             f'The reproduction report, `{REPRODUCTION}`, reads every claim against the '
             'paper. No model we have tried reaches '
             + ', '.join(f'`{name}`' for name in UNREACHED)
             + " (not the shipped profiles, not the calibration over the sensing chain's "
             'defensible ranges, not the 36 trials of the existence search over wide ranges); '
             + ' and '.join(f'`{name}`' for name in ONLY_WITHOUT_CLEANING)
             + ' held there only in swarms that neither gather at the source nor clean it.', '']
    labels = list(labels) if len(labels) == len(compared) else [
        ', '.join(f'{name} = {value}' for name, value in levels.items())
        for levels, _ in compared]
    for (levels, results), label in zip(compared, labels):
        if levels:
            lines += [f'### {label}', '']
        counts = {status: sum(r.status == status for r in results)
                  for status in claim_checks.STATUSES}
        lines += [', '.join(f'{count} {status}' for status, count in counts.items()
                            if count) + '.', '']
        frame = pd.DataFrame([{'claim': f'`{r.id}`', 'where': r.claim.where,
                               'the paper': r.claim.paper.replace('|', '/'),
                               'ours': r.ours.replace('|', '/'),
                               'holds?': f'**{r.status}**' if r.status == claim_checks.FAILS
                               else r.status} for r in results])
        lines += [markdown_table(frame), '']
    return lines


def software() -> dict[str, str]:
    """Versions of this software, Python and the libraries that shape the results."""
    versions = {'mona_swarm': __version__, 'python': platform.python_version()}
    for name in DEPENDENCIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = 'not installed'
    try:
        versions['git'] = subprocess.run(
            ['git', 'describe', '--always', '--dirty'], cwd=Path(__file__).parent,
            capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return versions


def plugins_lines(records: Sequence[dict[str, Any]]) -> list[str]:
    """The report's lines on the plug-ins the episodes ran (each file once, with its
    SHA-256), none without plug-ins."""
    seen: dict[tuple[str, str], str] = {}
    for record in records:
        for plugin in record.get('plugins') or []:
            if isinstance(plugin, dict):
                where = plugin.get('path') or plugin.get('module', '?')
                seen.setdefault((str(where), str(plugin.get('sha256', ''))),
                                str(plugin.get('origin', 'file')))
    return [f'- plug-in ({origin}): `{where}`, SHA-256 `{digest}`'
            for (where, digest), origin in seen.items()]


def differing_parameters(records: Sequence[dict[str, Any]]) -> list[str]:
    """Parameters other than the factors and the seed that differ between episodes."""
    values: dict[str, set] = {}
    for record in records:
        for section, fields in record.get('parameters', {}).items():
            if section == 'study' or not isinstance(fields, dict):
                continue
            for key, value in fields.items():
                name = f'{section}.{key}'
                if name not in ('episode.population', 'episode.seed', 'controller.speed'):
                    values.setdefault(name, set()).add(json.dumps(value))
    return sorted(name for name, seen in values.items() if len(seen) > 1)


def render(out: Path, table: pd.DataFrame, folders: Sequence[Path],
           records: Sequence[dict[str, Any]], drawn: Sequence[Figure],
           tables: dict[str, pd.DataFrame | str], *, sources: Sequence[str] = (),
           parameters_file: str | None = None,
           incomplete: Mapping[Path, Sequence[Finding]] | None = None,
           compared: Sequence[tuple[dict[str, Any], Sequence[claim_checks.ClaimResult]]] = (),
           variants: pd.DataFrame | None = None, matrix: Path | None = None) -> str:
    """The text of report.md (``incomplete``: see :func:`analyse`; ``compared``: the claims
    checked per level of the design factors,
    :func:`~swarm_supervisor.analysis.checks.evaluate_levels`;
    ``variants``: :func:`variant_table`; ``matrix``: sensitivity.md, if written).
    """
    levels = {key: sorted(table[key].unique().tolist()) for key in study.KEYS}
    ends = table.groupby(list(study.KEYS))['t'].max()
    runners = sorted({record.get('runner', 'unknown') for record in records})
    lines = [
        '# Mona swarm study: pollution-source localisation and cleanup (BEECLUST)', '',
        f'Generated {time.strftime("%Y-%m-%d %H:%M:%S")} from {len(folders)} episodes '
        f'({", ".join(runners)} runner) in '
        + (', '.join(f'`{s}`' for s in sources) if sources else f'`{out}`') + '.', '',
        '## Design', '',
        f'- population N: {", ".join(map(str, levels["population"]))} robots',
        f'- speed v_r: {", ".join(figures.speed_label(v) for v in levels["speed"])}',
        f'- seeds: {", ".join(map(str, levels["seed"]))} (one episode per seed and cell)',
        f'- episode length: {_range(ends)} s, metrics sampled every '
        f'{float(np.median(np.diff(np.unique(table["t"])))):g} s',
    ]
    if parameters_file:
        lines.append(f'- every parameter: [`{parameters_file}`]({parameters_file}) (ROS 2 '
                     'parameter file; `mona-swarm study --config` reads it back); each episode '
                     "folder's episode.json also records its own")
    else:
        lines.append("- every parameter: in each episode folder's episode.json")
    lines.append(profile.describe(records))
    lines += plugins_lines(records)
    factors = study.design_factors(table)
    for factor in factors:
        lines.append(f'- factor `{factor}`: '
                     + ', '.join(str(v) for v in sorted(table[factor].unique().tolist())))
    differ = [name for name in differing_parameters(records) if name not in factors]
    if differ:
        lines.append(f'- **warning**: these parameters differ between episodes: '
                     f'{", ".join(differ)}')
    if incomplete:
        lines.append(f'- **warning**: {len(incomplete)} of {len(folders)} episodes are '
                     f'incomplete (analysed anyway, `--allow-incomplete`); what each record '
                     f'lacks:')
        for folder, findings in incomplete.items():
            lines.append(f'  - `{Path(folder).name}`: '
                         + '; '.join(str(finding) for finding in findings))
    lines.append(f'- tidy table of every sample: [`{study.TABLE_FILE}`]({study.TABLE_FILE}) '
                 f'({len(table)} rows)')
    lines += ['', '## What the results show', '',
              '*Computed from the table above; medians over seeds.*', '']
    fitted = {name: frame for name, frame in tables.items() if isinstance(frame, pd.DataFrame)}
    lines += [f'- {line}' for line in (reading(table, fitted) if len(fitted) == len(tables)
                                       else unfitted_reading(table, tables))]
    lines += [''] + compared_section(compared, [label for label, _ in figures.variants(table)])
    if matrix is not None:
        lines += [f'Which verdicts change with which factor level, claim by claim: '
                  f'[`{matrix.name}`]({matrix.name}) (and `{sensitivity.MATRIX_CSV}`).', '']
    lines += ['', '## Figures', '']
    for figure in drawn:
        lines.append(f'### {figure.title}')
        lines.append('')
        if figure.file:
            lines.append(f'![{figure.title}]({figure.file})')
            lines.append('')
        if figure.note:
            lines.append(f'*Note: {figure.note}.*')
            lines.append('')
    lines += tables_section(table, tables, variants)
    summary = cleaning_summary(table)
    summary['speed'] = summary['speed'].map(figures.speed_label)
    lines += ['### Cleaning by cell', '',
              'Median over seeds of the time until the mean cue is half its initial value '
              '(- when most seeds never got there) and of the fraction left at the end.', '',
              markdown_table(summary, {'t_half_s': '.0f', 'final_fraction': '.3f',
                                       'end_s': '.0f'}), '']
    lines += ['## Timing', ''] + timing_section(records, folders, out) + ['']
    lines += ['## Software', '']
    lines += [f'- {name}: {version}' for name, version in software().items()]
    return '\n'.join(lines) + '\n'


def _range(values: pd.Series) -> str:
    low, high = float(values.min()), float(values.max())
    return f'{low:g}' if low == high else f'{low:g}-{high:g}'
