"""Figures beyond the paper's: each source's share of the cue (several sources) and one
figure per added metric (:func:`fig_metric`, for each metric of
``swarm_metrics.metrics.METRICS`` with a plot label that the table has). Each writes one
PNG and returns a note, as the paper's figures (:mod:`.figures`) do.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from swarm_metrics.metrics import METRICS, PAPER_METRICS, SOURCE_COLUMNS, source_names
from swarm_supervisor.analysis.figures import (
    FigureSkipped,
    colours,
    finish,
    from_zero,
    grid,
    over_seeds,
    seeds_label,
    speed_label,
    variants,
)

#: Drawn when the episodes have several sources (docs/model.md "Leaks beyond the paper").
FIG_SOURCES = 'fig_sources.png'
#: The figure of a metric beyond the paper's (its name filled in).
FIG_METRIC = 'fig_metric_{}.png'


def fig_sources(table: pd.DataFrame, path: str | Path) -> str:
    """Each source's share of the initial cue vs time (``mean_cue_fraction_<name>``), one
    curve per N (median over seeds), one panel per source and speed (and per level of the
    design's extra factors). Returns a note ('' when there is nothing to add)."""
    names = source_names(list(table.columns))
    if not names:
        raise FigureSkipped('the episodes have one source')
    speeds = sorted(table['speed'].unique(), reverse=True)
    facets = variants(table)
    palette = colours(table['population'].unique())
    panels = [(name, label, rows, speed) for label, rows in facets for name in names
              for speed in speeds]
    fig, axes = grid(len(panels), len(names) * len(speeds), (4.2, 3.2), sharey=True)
    for k, (ax, (name, label, rows, speed)) in enumerate(zip(axes, panels)):
        column = SOURCE_COLUMNS[0].format(name)
        stats = over_seeds(rows, column)
        for n in sorted(stats['population'].unique(), reverse=True):
            curve = stats[(stats['speed'] == speed) & (stats['population'] == n)]
            ax.plot(curve['t'], curve['median'], color=palette[n], linewidth=1.6,
                    label=f'N = {n}')
        ax.set_title(f'({chr(ord("a") + k) if k < 26 else "-"}) source {name!r}, '
                     f'v = {speed_label(speed)}' + (f'\n{label}' if label else ''),
                     fontsize='small')
        ax.set_xlabel('time (s)')
        ax.set_xlim(0, table['t'].max())
        ax.grid(alpha=0.3)
        if ax.get_subplotspec().is_first_col():
            ax.set_ylabel('cue in its region\n(fraction of the initial total)')
    from_zero(axes)
    axes[0].legend(title='robots', fontsize='small')
    fig.suptitle('Cue near each source: the cells nearer to it than to any other, where the '
                 f'sources are (median over {seeds_label(table)})')
    finish(fig, path)
    return ''


def extra_metrics(table: pd.DataFrame) -> list[str]:
    """The metrics beyond the paper's that have a plot label and a column in ``table``, in
    table order: each gets a :func:`fig_metric`."""
    return [name for name, metric in METRICS.items() if name not in PAPER_METRICS
            and metric.label is not None and name in table.columns]


def fig_metric(table: pd.DataFrame, path: str | Path, name: str) -> str:
    """A metric beyond the paper's vs time: one curve per N (median over seeds, band: min to
    max), one panel per speed (and per level of the design's extra factors, :func:`variants`),
    the y axis labelled by the metric's entry. Returns a note ('' when there is nothing to
    add).

    Raises:
        FigureSkipped: ``table`` has no column ``name``.
    """
    if name not in table.columns:
        raise FigureSkipped(f'the table has no column {name}')
    metric = METRICS[name]
    speeds = sorted(table['speed'].unique(), reverse=True)
    facets = variants(table)
    palette = colours(table['population'].unique())
    panels = [(label, rows, speed) for label, rows in facets for speed in speeds]
    fig, axes = grid(len(panels), len(speeds) * (2 if len(facets) > 1 else 1), (5.2, 3.6),
                      sharey=True)
    for k, (ax, (label, rows, speed)) in enumerate(zip(axes, panels)):
        stats = over_seeds(rows, name)
        for n in sorted(stats['population'].unique(), reverse=True):
            curve = stats[(stats['speed'] == speed) & (stats['population'] == n)]
            ax.fill_between(curve['t'], curve['min'], curve['max'], color=palette[n],
                            alpha=0.25, linewidth=0)
            ax.plot(curve['t'], curve['median'], color=palette[n], linewidth=1.6,
                    label=f'N = {n}')
        letter = f'({chr(ord("a") + k)}) ' if k < 26 else ''
        ax.set_title(f'{letter}v = {speed_label(speed)}' + (f'\n{label}' if label else ''),
                     fontsize='small')
        ax.set_xlabel('time (s)')
        ax.set_xlim(0, table['t'].max())
        ax.grid(alpha=0.3)
        if ax.get_subplotspec().is_first_col():
            ax.set_ylabel(metric.label or name)
    if not metric.unit:
        for ax in axes:
            ax.set_ylim(0, 1.02)
    else:
        from_zero(axes)
    axes[0].legend(title='robots', fontsize='small')
    fig.suptitle(f'{metric.doc} (median and min-max over {seeds_label(table)})')
    finish(fig, path)
    return ''
