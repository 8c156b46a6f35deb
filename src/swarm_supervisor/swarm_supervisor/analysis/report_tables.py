"""The report's ANOVA tables and its timing section, and markdown tables.

The ANOVA of a study may not be fittable: one episode, or one cell with one seed, leaves no
residual degrees of freedom. :func:`fit_anovas` then gives the reason instead of a table,
and the report says it where the table would be (and writes no ANOVA CSV), so everything
else the episodes show is still reported.

Per-episode wall times are shares of a batch: the batched engine steps a batch's episodes
together, so each one's wall time is the batch's divided by its size
(:func:`swarm_supervisor.engine.run_batch`); :func:`timing_section` says so.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from swarm_supervisor import study
from swarm_supervisor.analysis import anova as anova_tables
from swarm_supervisor.analysis import figures
from swarm_supervisor.analysis.reading import ANOVA_FILES, curve_reading, variant_cells

#: What the report says of each episode's wall time (its share of its batch's).
BATCH_SHARE = ("Episodes run in batches stepped together (`--batch-size`) share their batch's "
               "wall time: each episode's is the batch's divided by its number of episodes, "
               'so a small population looks as slow as a large one batched with it (N = 50 '
               'as fast as N = 10). Compare wall times across batch sizes, not across cells.')


def fit_anovas(table: pd.DataFrame) -> dict[str, pd.DataFrame | str]:
    """The ANOVA of each response (:data:`ANOVA_FILES`), or why it cannot be fitted."""
    fitted: dict[str, pd.DataFrame | str] = {}
    for response in ANOVA_FILES:
        try:
            fitted[response] = anova_tables.anova(table, response)
        except ValueError as reason:
            fitted[response] = str(reason).removeprefix(f'ANOVA of {response}: ')
    return fitted


def write_anovas(out: Path, fitted: dict[str, pd.DataFrame | str]) -> None:
    """Write each fitted ANOVA's CSV; remove the CSV of one that cannot be fitted (an
    earlier study's table must not stand beside these results)."""
    for response, name in ANOVA_FILES.items():
        result = fitted[response]
        if isinstance(result, pd.DataFrame):
            anova_tables.write_anova(result, out / name)
        else:
            (out / name).unlink(missing_ok=True)


def unfitted_reading(table: pd.DataFrame, fitted: dict[str, pd.DataFrame | str]) -> list[str]:
    """The reading of the results (as :func:`~swarm_supervisor.analysis.reading.reading`)
    when an ANOVA could not be fitted: the curves, then why each ANOVA is missing."""
    lines = []
    facets = figures.variants(table)
    if len(facets) > 1:
        for label, subset in facets:
            lines += [f'[{label}] {line}' for line in curve_reading(subset)]
    else:
        lines += curve_reading(table)
    for response, label in (('mean_cue', 'the mean cue'), ('coherency', 'coherency')):
        result = fitted[response]
        if isinstance(result, str):
            lines.append(f'ANOVA of {label}: not fitted: {result}.')
    return lines


def tables_section(table: pd.DataFrame, fitted: dict[str, pd.DataFrame | str],
                   variants: pd.DataFrame | None) -> list[str]:
    """'## Tables': tables 2 and 3 (or why each cannot be fitted) and F per variant."""
    extra = study.design_factors(table)
    lines = ['## Tables', '',
             'ANOVA with time, population, speed'
             + ''.join(f', {name}' for name in extra) + ' as categorical factors (main effects, '
             'type-II sums of squares, statsmodels `ols` + `anova_lm`). Time enters as '
             f'{anova_tables.DEFAULT_LEVELS} levels: each episode contributes its value at '
             't = ' + ', '.join(f'{t:g}' for t in anova_tables.time_levels(table)) +
             ' s. Successive samples of one episode are not independent, so p-values are '
             "optimistic; eta^2 is the factor's share of the total sum of squares.", '']
    formats = {'sum_sq': '.4g', 'F': '.4g', 'p': '.3g', 'eta_sq': '.3f', 'levels': '.0f'}
    for response, name in ANOVA_FILES.items():
        label = 'Table 2: mean cue' if response == 'mean_cue' else 'Table 3: coherency'
        result = fitted[response]
        if isinstance(result, str):
            lines += [f'### {label}', '',
                      f"**Not fitted**: {result}. This design cannot separate the factors' "
                      'effects from the noise between episodes; `' + name + '` is not written. '
                      'The figures and the reading above still hold for these episodes.', '']
            continue
        shown = result.astype({'p': object})
        shown.loc[shown['p'] == 0, 'p'] = '< 1e-300'
        lines += [f'### {label} ([`{name}`]({name}))', '',
                  markdown_table(shown, formats), '']
    if variants is not None:
        lines += ['### How time and samples enter: F per ANOVA variant', '',
                  'The paper does not say how time and the samples entered its ANOVA. F of each '
                  'factor under each variant (`swarm_supervisor.analysis.anova`, `variant=`); '
                  'the tables '
                  'above are `levels`. ' + '; '.join(f'`{name}`: {text}' for name, text in
                                                     anova_tables.VARIANT_TEXT.items()) + '.',
                  '', markdown_table(variant_cells(variants)), '']
    return lines


def markdown_table(frame: pd.DataFrame, formats: dict[str, str] | None = None) -> str:
    """A DataFrame as a GitHub markdown table (NaN shown as '-'; strings as they are)."""
    formats = formats or {}

    def cell(column: str, value: Any) -> str:
        if isinstance(value, float) and np.isnan(value):
            return '-'
        if isinstance(value, str):
            return value
        spec = formats.get(column)
        return format(value, spec) if spec else str(value)

    lines = ['| ' + ' | '.join(frame.columns) + ' |',
             '|' + '---|' * len(frame.columns)]
    for row in frame.itertuples(index=False):
        lines.append('| ' + ' | '.join(cell(c, v) for c, v in zip(frame.columns, row)) + ' |')
    return '\n'.join(lines)


def timing_section(records: Sequence[dict[str, Any]], folders: Sequence[Path],
            out: Path) -> list[str]:
    """'## Timing': each cell's wall time per episode (a share of its batch's, said so), and
    every study run into ``out`` with how it ended (study.json)."""
    lines = []
    frame = pd.DataFrame([{**study.episode_key(folder),
                           'wall': record.get('wall_time_s', np.nan),
                           'rtf': record.get('real_time_factor', np.nan)}
                          for folder, record in zip(folders, records)])
    if frame['wall'].notna().any():
        cells = frame.groupby(['population', 'speed']).agg(
            episodes=('wall', 'size'), median_wall_s=('wall', 'median'),
            max_wall_s=('wall', 'max'), real_time_factor=('rtf', 'median')).reset_index()
        cells['speed'] = cells['speed'].map(figures.speed_label)
        lines += ['Wall time of one episode (the simulation alone, from each episode.json):',
                  '', markdown_table(cells, {'median_wall_s': '.1f', 'max_wall_s': '.1f',
                                             'real_time_factor': '.0f'}), '',
                  f'Sum over the {frame["wall"].notna().sum()} episodes: '
                  f'{frame["wall"].sum():.0f} s of wall time (one core each).', '',
                  BATCH_SHARE]
    invocations = study.read_invocations(out)
    if invocations:
        lines += ['', 'Study runs into this folder (total wall time; the CPU time the episodes '
                  'used, which does not grow when other programs share the machine):', '']
        for entry in invocations:
            cpu = entry.get('cpu_time_s')
            lines.append(f'- {entry["started"]}: ran {entry["ran"]}, kept {entry["kept"]} of '
                         f'{entry["episodes"]} episodes on {entry["jobs"]} worker(s) in '
                         f'{entry["wall_time_s"]:.1f} s'
                         + (f'; episodes used {cpu:.0f} s of CPU' if cpu else '')
                         + (f'; **{entry["outcome"]}**, {entry.get("complete", "?")} episodes '
                            'complete after it' if entry.get('outcome', 'finished')
                            != 'finished' else ''))
    return lines or ['No timing recorded in these episodes.']
