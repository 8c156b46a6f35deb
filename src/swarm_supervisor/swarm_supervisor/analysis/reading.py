"""The reading of a study's results: numbers computed from the tidy table, in words.

report.md's "What the results show": the time each cell takes to halve the cue and what it
leaves, whether more and faster robots clean faster, whether the ratio near the source and the
coherency settle, and what the ANOVA tables say; and the F of each factor under each ANOVA
variant.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from swarm_supervisor import study
from swarm_supervisor.analysis import anova as anova_tables
from swarm_supervisor.analysis import figures, speed_effect

ANOVA_FILES = {'mean_cue': 'anova_cue.csv', 'coherency': 'anova_coherency.csv'}
ALPHA = 0.05  #: significance level for the reading of the ANOVA tables
SETTLE_SHARE = 0.1  #: settling compares the last tenth of the episode with the one before
SETTLE_TOLERANCE = 0.05  #: settled: that change is within 5 % of the curve's range


def cleaning_summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per (population, speed) and level of each design factor: median over seeds of the time
    to halve the mean cue (NaN when most seeds never did) and of the final fraction of the
    initial cue left."""
    rows = []
    factors = study.design_factors(table)
    for key, cell in table.groupby(['population', 'speed', *factors]):
        n, v, levels = key[0], key[1], dict(zip(factors, key[2:]))
        halves, finals = [], []
        for _, episode in cell.groupby('seed'):
            episode = episode.sort_values('t')
            below = episode.loc[episode['mean_cue_fraction'] <= 0.5, 't']
            halves.append(below.iloc[0] if len(below) else np.inf)
            finals.append(episode['mean_cue_fraction'].iloc[-1])
        half = float(np.median(halves))
        rows.append({'population': n, 'speed': v, **levels, 'seeds': len(finals),
                     't_half_s': half if np.isfinite(half) else np.nan,
                     'final_fraction': float(np.median(finals)),
                     'end_s': float(cell['t'].max())})
    return pd.DataFrame(rows)


def settling(table: pd.DataFrame, column: str, speed: float,
             populations: Sequence[int]) -> pd.DataFrame:
    """Whether the median curve of ``column`` has settled by the end of the episode.

    Compares the mean of the last tenth of the median-over-seeds curve with the tenth before
    it; settled when the change is within 5 % of the curve's range (max - min).
    """
    rows = []
    stats = figures.over_seeds(table[table['speed'] == speed], column)
    for n in populations:
        curve = stats[stats['population'] == n].sort_values('t')
        t, y = curve['t'].to_numpy(), curve['median'].to_numpy()
        end = t.max()
        last = y[t > end * (1 - SETTLE_SHARE)]
        before = y[(t > end * (1 - 2 * SETTLE_SHARE)) & (t <= end * (1 - SETTLE_SHARE))]
        span = float(np.nanmax(y) - np.nanmin(y))
        change = float(np.nanmean(last) - np.nanmean(before))
        peak = int(np.nanargmax(y))
        rows.append({'population': n, 'peak': float(y[peak]), 'peak_t_s': float(t[peak]),
                     'start': float(y[0]), 'end_mean': float(np.nanmean(last)),
                     'change': change,
                     'settled': bool(abs(change) <= SETTLE_TOLERANCE * span) if span > 0
                     else True})
    return pd.DataFrame(rows)


def _cm(speed: float) -> str:
    return figures.speed_label(speed)


def _order_claim(summary: pd.DataFrame, speed: float) -> str:
    """Does the final cue fall as N grows at this speed?"""
    cells = summary[summary['speed'] == speed].sort_values('population')
    finals = cells['final_fraction'].to_numpy()
    listing = ', '.join(f'N = {n}: {f:.1%}' for n, f in zip(cells['population'], finals))
    if len(finals) < 2:
        return f'only one population at {_cm(speed)} ({listing})'
    verdict = 'falls as N grows' if np.all(np.diff(finals) < 0) else \
        'does not fall monotonically with N'
    return f'at {_cm(speed)} the cue left at the end {verdict} ({listing})'


def _speed_claim(summary: pd.DataFrame) -> str:
    """Do faster robots leave less cue, at every N?"""
    speeds = sorted(summary['speed'].unique())
    if len(speeds) < 2:
        return 'one speed only: the speed effect is not tested'
    slow, fast = speeds[0], speeds[-1]
    wins = []
    for n, cell in summary.groupby('population'):
        by_speed = cell.set_index('speed')['final_fraction']
        if slow in by_speed and fast in by_speed:
            wins.append((n, by_speed[fast] < by_speed[slow]))
    faster = [n for n, win in wins if win]
    if len(faster) == len(wins):
        return f'{_cm(fast)} robots leave less cue than {_cm(slow)} robots at every N'
    return (f'{_cm(fast)} robots leave less cue than {_cm(slow)} robots at N = '
            f'{", ".join(map(str, faster)) or "none"} of {", ".join(str(n) for n, _ in wins)}')


def p_value(p: float) -> str:
    """'= 0.0027', or '< 1e-300' where the F distribution's tail underflows to 0."""
    return '< 1e-300' if p == 0 else f'= {p:.2g}'


def _anova_claim(name: str, frame: pd.DataFrame) -> str:
    parts = []
    for _, row in frame[frame['factor'] != 'residual'].iterrows():
        if np.isnan(row['p']):
            parts.append(f'{row["factor"]}: not tested (one level)')
        else:
            verdict = 'significant' if row['p'] < ALPHA else 'not significant'
            parts.append(f'{row["factor"]} {verdict} (F = {row["F"]:.3g}, '
                         f'p {p_value(row["p"])}, eta^2 = {row["eta_sq"]:.2f})')
    return f'ANOVA of {name}: ' + '; '.join(parts) + '.'


def reading(table: pd.DataFrame, tables: dict[str, pd.DataFrame]) -> list[str]:
    """The short reading of the results, as bullet points computed from the data; with a
    sweep, the curves are read at each level of the design factors apart (pooling them would
    mix different models)."""
    lines = []
    facets = figures.variants(table)
    if len(facets) > 1:  # labelled as the figures' panels
        for label, subset in facets:
            lines += [f'[{label}] {line}' for line in curve_reading(subset)]
    else:
        lines += curve_reading(table)
    lines.append(_anova_claim('the mean cue', tables['mean_cue']))
    lines.append(_anova_claim('coherency', tables['coherency']))
    if not study.design_factors(table):  # a sweep's levels are different models
        try:
            lines.append(speed_effect.describe(speed_effect.speed_effect(table)))
        except ValueError:  # one speed, or an unbalanced design: no such reading
            pass
    return lines


def curve_reading(table: pd.DataFrame) -> list[str]:
    """The reading of the curves of one model (one level of each design factor)."""
    summary = cleaning_summary(table)
    lines = []
    timed = summary.dropna(subset=['t_half_s'])
    if len(timed):
        best = timed.sort_values(['t_half_s', 'final_fraction']).iloc[0]
        lines.append(f'Fastest cleaning: N = {best["population"]:.0f} at {_cm(best["speed"])} '
                     f'halves the mean cue in {best["t_half_s"]:.0f} s (median over seeds) and '
                     f'leaves {best["final_fraction"]:.1%} of it after {best["end_s"]:.0f} s.')
        never = summary[summary['t_half_s'].isna()]
        if len(never):
            lines.append('Never halved the cue (median over seeds): ' + ', '.join(
                f'N = {n:.0f} at {_cm(v)}' for n, v in zip(never['population'],
                                                            never['speed'])) + '.')
    else:
        best = summary.sort_values('final_fraction').iloc[0]
        lines.append(f'No cell halved the mean cue; the least left: N = '
                     f'{best["population"]:.0f} at {_cm(best["speed"])}, '
                     f'{best["final_fraction"]:.1%} after {best["end_s"]:.0f} s.')
    for speed in sorted(summary['speed'].unique(), reverse=True):
        lines.append('More robots: ' + _order_claim(summary, speed) + '.')
    lines.append('Faster robots: ' + _speed_claim(summary) + '.')
    speed = figures.choose_speed(table['speed'].unique())
    populations = figures.choose_populations(
        table.loc[table['speed'] == speed, 'population'].unique())
    for column, label, unit in (('ratio_near_source', 'ratio near the source', ''),
                                ('coherency', 'coherency', ' m')):
        settled = settling(table, column, speed, populations)
        parts = [f'N = {row.population}: peak {row.peak:.2f}{unit} at {row.peak_t_s:.0f} s, '
                 f'{row.end_mean:.2f}{unit} over the last tenth '
                 f'({"settled" if row.settled else "still changing"}, {row.change:+.3f}{unit} '
                 'from the tenth before)' for row in settled.itertuples()]
        lines.append(f'The {label} at {_cm(speed)}: ' + '; '.join(parts) + '.')
    return lines


def variant_table(table: pd.DataFrame) -> pd.DataFrame:
    """F per factor (rows) under each ANOVA variant (columns), for the mean cue and coherency,
    with each variant's number of observations."""
    frames = []
    for response in ANOVA_FILES:
        frame = anova_tables.compare_variants(table, response)
        frame.insert(0, 'response', response)
        frames.append(frame)
    return pd.concat(frames, ignore_index=True)


def variant_cells(variants: pd.DataFrame) -> pd.DataFrame:
    """The variant table as text: F to 4 significant digits, observations as integers."""
    shown = variants.copy()
    for column in anova_tables.VARIANTS:
        shown[column] = [('-' if not np.isfinite(value) else
                          f'{value:.0f}' if factor == 'observations' else f'{value:.4g}')
                         for factor, value in zip(shown['factor'], shown[column])]
    return shown
