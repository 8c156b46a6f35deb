"""The paper's figures 3-6 from the study's tidy table (and, for fig. 3, cue-map snapshots),
and the plotting parts the figures beyond the paper's share (:mod:`.beyond_figures`).

A design with extra factors (``study.factors``) gets one panel per factor level in figures
4-6 (:func:`variants`); the paper's layout is kept otherwise.

Each ``fig*`` function writes one PNG and returns a note: empty when the figure shows exactly
what the paper's does, otherwise what it shows instead (a custom design may lack N = 30 or
8 cm/s; the nearest levels are used and the title says so).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TypeVar

import matplotlib

matplotlib.use('Agg')  # files only; never needs a display
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from swarm_supervisor.outputs.pictures import draw_cue_map  # noqa: E402
from swarm_supervisor.study.table import design_factors  # noqa: E402
from swarm_world.arena import Obstacle  # noqa: E402

FIG3 = 'fig3_cue_maps.png'
FIG4 = 'fig4_mean_cue.png'
FIG5 = 'fig5_ratio_near_source.png'
FIG6 = 'fig6_coherency.png'

#: The paper's levels: fig. 3 at N = 30, figs. 5 and 6 at N = 10, 30, 50, both at 8 cm/s.
PAPER_SPEED = 0.08
PAPER_POPULATIONS = (10, 30, 50)
FIG3_POPULATION = 30
FIG3_TIMES = (0.0, 1000.0, 4000.0)
PAPER_DURATION = 4000.0
DPI = 130
#: The label of the variant of a one-at-a-time design that keeps every factor at the
#: parameter file's value.
BASE_LABEL = 'as the parameter file'


#: A design level: a population or a speed.
Level = TypeVar('Level', int, float)


class FigureSkipped(Exception):
    """A figure cannot be drawn from the data at hand (the message says why)."""


def nearest(levels: Sequence[Level], target: float) -> Level:
    """The level closest to ``target`` (the smaller one on a tie)."""
    return min(sorted(levels), key=lambda level: abs(level - target))


def choose_speed(levels: Sequence[float], target: float = PAPER_SPEED) -> float:
    """The paper's speed if present, else the nearest one in the design."""
    return nearest(levels, target)


def choose_populations(levels: Sequence[int],
                       targets: Sequence[int] = PAPER_POPULATIONS) -> list[int]:
    """The populations to compare: the paper's if all present; else as many distinct levels
    as there are targets, nearest first (all of them when the design has that few)."""
    levels = sorted(levels)
    if len(levels) <= len(targets):
        return levels
    chosen = []
    for target in targets:
        free = [level for level in levels if level not in chosen]
        chosen.append(nearest(free, target))
    return sorted(chosen)


def speed_label(speed: float) -> str:
    """A speed in m/s as the paper writes it, e.g. '8 cm/s'."""
    return f'{speed * 100:g} cm/s'


def seeds_label(table: pd.DataFrame) -> str:
    """How many seeds each curve's statistic is over, e.g. '6 seeds' or '2-6 seeds'."""
    counts = table.groupby(['population', 'speed'])['seed'].nunique()
    low, high = int(counts.min()), int(counts.max())
    return f'{low} seed{"s" * (high > 1)}' if low == high else f'{low}-{high} seeds'


def over_seeds(table: pd.DataFrame, column: str) -> pd.DataFrame:
    """Median, min and max of ``column`` over seeds, per population, speed and t."""
    grouped = table.groupby(['population', 'speed', 't'])[column]
    return grouped.agg(['median', 'min', 'max']).reset_index()


def colours(populations: Sequence[int]) -> dict[int, tuple]:
    """One colour per population, light to dark with N, the same in every figure."""
    cmap = plt.get_cmap('viridis')
    levels = sorted(populations)
    span = max(len(levels) - 1, 1)
    return {n: cmap(0.8 * (1 - k / span)) for k, n in enumerate(levels)}


def _substitution(populations: Sequence[int], speed: float) -> str:
    """The note for figures 5 and 6 when the design lacks the paper's levels."""
    notes = []
    if list(populations) != list(PAPER_POPULATIONS):
        notes.append('N = ' + ', '.join(map(str, populations)) + ' (the paper: 10, 30, 50)')
    if not np.isclose(speed, PAPER_SPEED):
        notes.append(f'{speed_label(speed)} (the paper: 8 cm/s)')
    return '; '.join(notes)


def finish(fig, path: str | Path) -> None:
    """Save ``fig`` to ``path`` at the figures' resolution and free it."""
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


def fig3_cue_maps(snapshots: Mapping[str, np.ndarray], path: str | Path, *, population: int,
                  speed: float, seed: int, arena_side: float, body_radius: float,
                  peak: float, duration: float, substitute: str = '',
                  obstacles: Sequence[Obstacle] = ()) -> str:
    """Cue maps with the robots at the snapshots nearest to t = 0, 1000 and 4000 s.

    Args:
        snapshots: a snapshots.npz's arrays (``times`` [T], ``cue`` [T, H, W],
            ``poses`` [T, N, 3]).
        duration: the episode length; for a shorter episode than the paper's the target times
            are scaled to it (0, 1/4 and all of the episode).
        substitute: a note when the episode is not the paper's N = 30 at 8 cm/s.
        obstacles: the arena's obstacles, drawn on every map.

    Raises:
        FigureSkipped: the snapshots hold no cue map.
    """
    times = np.asarray(snapshots.get('times', []), dtype=float)
    if len(times) == 0:
        raise FigureSkipped('the episode kept no cue-map snapshots')
    scale = duration / PAPER_DURATION
    picks = sorted({int(np.argmin(np.abs(times - target * scale))) for target in FIG3_TIMES})
    notes = [substitute] if substitute else []
    wanted = [target * scale for target in FIG3_TIMES]
    if any(not np.isclose(times[k], w) for k, w in zip(picks, wanted)) or len(picks) < 3:
        notes.append('snapshots at t = ' + ', '.join(f'{times[k]:g}' for k in picks) +
                     ' s (the paper: 0, 1000, 4000 s)')
    fig, axes = plt.subplots(1, len(picks), figsize=(4.3 * len(picks) + 1.2, 4.6),
                             squeeze=False, layout='constrained')
    for ax, k, letter in zip(axes[0], picks, 'abc'):
        level = float(snapshots['cue'][k].mean())
        image = draw_cue_map(ax, snapshots['cue'][k], snapshots['poses'][k], arena_side,
                             body_radius, peak=peak, obstacles=obstacles,
                             title=f'({letter}) t = {times[k]:g} s, mean cue {level:.1f}')
    fig.colorbar(image, ax=axes[0].tolist(), label='cue intensity (0..255)', shrink=0.9)
    fig.suptitle(f'Fig. 3  Cue map and robots (white discs, red tick = heading): '
                 f'N = {population}, {speed_label(speed)}, seed {seed}'
                 + (f'\n{"; ".join(notes)}' if notes else ''))
    finish(fig, path)
    return '; '.join(notes)


def variants(table: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    """The table split by the design's extra factors (one facet each), with a label.

    Without extra factors: one variant, the whole table, label ''. When every variant differs
    from the most common value of each factor in at most one factor (a one-at-a-time
    design), a label names only that factor ('mona.ir_range = 0.05', or 'as the parameter
    file'); otherwise it names every factor.
    """
    factors = design_factors(table)
    if not factors:
        return [('', table)]
    groups = [(values if isinstance(values, tuple) else (values,), rows)
              for values, rows in table.groupby(factors, sort=True)]
    modal = [pd.Series([values[k] for values, _ in groups]).mode()[0]
             for k in range(len(factors))]
    differing = [[k for k, value in enumerate(values) if value != modal[k]]
                 for values, _ in groups]
    one_at_a_time = len(factors) > 1 and all(len(d) <= 1 for d in differing)
    out = []
    for (values, rows), diff in zip(groups, differing):
        shown = diff if one_at_a_time else range(len(factors))
        label = ', '.join(f'{factors[k]} = {values[k]}' for k in shown) or BASE_LABEL
        out.append((label, rows))
    return out


def grid(panels: int, columns: int, size: tuple[float, float], **options):
    """A figure with ``panels`` axes in rows of ``columns``; unused axes are hidden."""
    columns = max(1, min(columns, panels))
    rows = -(-panels // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(size[0] * columns, size[1] * rows + 0.6),
                             squeeze=False, layout='constrained', **options)
    flat = list(axes.flat)
    for ax in flat[panels:]:
        ax.set_visible(False)
    return fig, flat[:panels]


def from_zero(axes: list) -> None:
    """Start the y axes at 0 once every panel is drawn: fixed any earlier, a shared axis would
    keep the first panel's top and clip the others (a leaking source's cue rises above it)."""
    for ax in axes:
        ax.set_ylim(bottom=0)


def fig4_mean_cue(table: pd.DataFrame, path: str | Path, *, initial_mean: float) -> str:
    """Mean cue vs time, one curve per N (median over seeds), one panel per speed (and per
    level of the design's extra factors, :func:`variants`).

    Args:
        initial_mean: the arena mean of the initial cue, for the percentage axis.
    """
    speeds = sorted(table['speed'].unique(), reverse=True)  # the paper: (a) 8, (b) 4 cm/s
    facets = variants(table)
    palette = colours(table['population'].unique())
    faceted = len(facets) > 1
    size = (4.2, 3.2) if faceted else (6.2, 4.6)
    fig, axes = grid(len(facets) * len(speeds), len(speeds) * (2 if faceted else 1), size,
                      sharey=True)
    panels = [(label, rows, speed) for label, rows in facets for speed in speeds]
    for k, (ax, (label, rows, speed)) in enumerate(zip(axes, panels)):
        stats = over_seeds(rows, 'mean_cue')
        for n in sorted(stats['population'].unique(), reverse=True):
            curve = stats[(stats['speed'] == speed) & (stats['population'] == n)]
            if len(curve):
                ax.plot(curve['t'], curve['median'], color=palette[n], linewidth=1.6,
                        label=f'N = {n}')
        letter = f'({chr(ord("a") + k)}) ' if k < 26 else ''
        ax.set_title(f'{letter}v = {speed_label(speed)}' + (f'\n{label}' if label else ''),
                     fontsize='small' if faceted else 'medium')
        ax.set_xlabel('time (s)')
        ax.set_xlim(0, table['t'].max())
        ax.grid(alpha=0.3)
        if k == 0 or not faceted:
            ax.legend(title='robots', fontsize='small', loc='best')
        if initial_mean > 0 and not faceted:
            right = ax.secondary_yaxis('right', functions=(
                lambda y: 100 * y / initial_mean, lambda p: p * initial_mean / 100))
            if ax is axes[-1]:
                right.set_ylabel('% of the initial mean cue')
        if ax.get_subplotspec().is_first_col():
            ax.set_ylabel('arena mean cue (0..255)' if faceted else
                          'arena mean cue (intensity units, 0..255)')
    from_zero(axes)
    fig.suptitle(f'Fig. 4  Mean cue vs time (median over {seeds_label(table)})')
    finish(fig, path)
    return '' if list(speeds) == [0.08, 0.04] else \
        'speeds ' + ', '.join(map(speed_label, speeds)) + ' (the paper: 8 and 4 cm/s)'


def _three_populations(table: pd.DataFrame) -> tuple[pd.DataFrame, list[int], float, str]:
    speed = choose_speed(table['speed'].unique())
    populations = choose_populations(table.loc[table['speed'] == speed, 'population'].unique())
    note = _substitution(populations, speed)
    chosen = table[(table['speed'] == speed) & table['population'].isin(populations)]
    return chosen, populations, speed, note


def _facet_grid(chosen: pd.DataFrame):
    """Figures 5 and 6: one panel per variant of the design (a single large one without
    extra factors); returns (variants, faceted?, figure, axes)."""
    facets = variants(chosen)
    faceted = len(facets) > 1
    fig, axes = grid(len(facets), 4, (4.2, 3.2) if faceted else (7.5, 4.6), sharey=True)
    return facets, faceted, fig, axes


def _place_title(fig, axes, title: str, faceted: bool) -> None:
    """Above the panels when faceted, else as the one panel's title."""
    if faceted:
        fig.suptitle(title)
    else:
        axes[0].set_title(title, fontsize='medium')


def fig5_ratio_near_source(table: pd.DataFrame, path: str | Path, *, source_radius: float,
                           smooth: float | None = None) -> str:
    """The fraction of robots within r_c of the source vs time, N = 10, 30, 50 at 8 cm/s
    (one panel per level of the design's extra factors, :func:`variants`).

    Args:
        smooth: the width (s) of the centred moving average over the median curve (default:
            1/200 of the episode, 20 s of the paper's 4000 s); the ratio of a few robots jumps
            in steps of 1/N from one second to the next.
    """
    chosen, populations, speed, note = _three_populations(table)
    if smooth is None:
        smooth = float(chosen['t'].max()) / 200
    palette = colours(table['population'].unique())
    facets, faceted, fig, axes = _facet_grid(chosen)
    for ax, (label, rows) in zip(axes, facets):
        stats = over_seeds(rows, 'ratio_near_source')
        for n in sorted(populations, reverse=True):
            curve = stats[stats['population'] == n].sort_values('t')
            step = float(np.median(np.diff(curve['t']))) if len(curve) > 1 else 1.0
            window = max(1, int(round(smooth / step)))
            line = curve['median'].rolling(window, center=True, min_periods=1).mean()
            ax.plot(curve['t'], line, color=palette[n], linewidth=1.6, label=f'N = {n}')
        ax.set_xlabel('time (s)')
        if ax.get_subplotspec().is_first_col():
            ax.set_ylabel(f'fraction within {source_radius:g} m of the source')
        ax.set_xlim(0, chosen['t'].max())
        ax.set_ylim(0, 1.02)  # a swarm all near the source sits at 1: keep that line visible
        ax.grid(alpha=0.3)
        if faceted:
            ax.set_title(label, fontsize='small')
    axes[0].legend(title='robots', loc='best', fontsize='small' if faceted else None)
    title = (f'Fig. 5  Robots near the source, v = {speed_label(speed)}\n'
             f'median over {seeds_label(chosen)}, {smooth:.3g}-s moving average'
             + (f'\n{note}' if note else ''))
    _place_title(fig, axes, title, faceted)
    finish(fig, path)
    return note


def fig6_coherency(table: pd.DataFrame, path: str | Path) -> str:
    """Median coherency vs time with a min-max band over seeds, N = 10, 30, 50 at 8 cm/s
    (one panel per level of the design's extra factors, :func:`variants`)."""
    chosen, populations, speed, note = _three_populations(table)
    palette = colours(table['population'].unique())
    facets, faceted, fig, axes = _facet_grid(chosen)
    for ax, (label, rows) in zip(axes, facets):
        stats = over_seeds(rows, 'coherency')
        for n in sorted(populations, reverse=True):
            curve = stats[stats['population'] == n].sort_values('t')
            ax.fill_between(curve['t'], curve['min'], curve['max'], color=palette[n],
                            alpha=0.25, linewidth=0)
            ax.plot(curve['t'], curve['median'], color=palette[n], linewidth=1.6,
                    label=f'N = {n} (median; band: min-max)')
        ax.set_xlabel('time (s)')
        if ax.get_subplotspec().is_first_col():
            ax.set_ylabel('coherency: mean pairwise distance (m)')
        ax.set_xlim(0, chosen['t'].max())
        ax.grid(alpha=0.3)
        if faceted:
            ax.set_title(label, fontsize='small')
    from_zero(axes)
    axes[0].legend(title='robots', fontsize='small')
    title = (f'Fig. 6  Coherency (lower = tighter swarm), v = {speed_label(speed)}\n'
             f'median and min-max over {seeds_label(chosen)}' + (f'\n{note}' if note else ''))
    _place_title(fig, axes, title, faceted)
    finish(fig, path)
    return note
