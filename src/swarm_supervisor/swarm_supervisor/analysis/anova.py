"""Tables 2 and 3: ANOVA of the mean cue and of coherency with time, population and speed.

Time, population, speed and any design factor of a sweep
(:func:`swarm_supervisor.study.table.design_factors`, e.g. ``mona.ir_range``) are factors of a
main-effects linear model fitted by ordinary least squares (statsmodels ``ols``), tested with
type-II sums of squares (``anova_lm(typ=2)``). The paper does not say how time and the samples
entered its ANOVA, so four variants (:data:`VARIANTS`) are offered:

- ``levels`` (the default, written to anova_cue.csv and anova_coherency.csv): every episode
  contributes one observation per *time level*, its value at t = D/k, 2D/k, ..., D (D the
  episode length, k = ``levels``, 10 by default: every 400 s in the paper's 4000 s
  episodes); time is categorical.
- ``samples``: every sample after t = 0, time categorical with the same k levels (a sample
  belongs to the level that ends its interval).
- ``medians``: the median over seeds of each cell (population, speed, design factors) at each
  time level, so seeds drop out and the residual is what the main effects leave of the
  median curves; time categorical.
- ``covariate``: the observations of ``levels``, with time a numeric covariate (1 df, a
  linear trend).

t = 0 is left out: every episode starts from the same cue, so it carries no information about
the factors. The observations of one episode are not independent (repeated measures), so the
p-values of every variant, most of all time's, are optimistic; the more samples per episode
a variant takes, the larger its F values, without more information.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from swarm_supervisor.study.table import design_factors

#: The design's factors, as the tables name them ('time' is the tidy table's column t); a
#: sweep's extra factors (:func:`swarm_supervisor.study.table.design_factors`) follow them.
FACTORS = ('time', 'population', 'speed')
TABLE_COLUMNS = ('factor', 'levels', 'df', 'sum_sq', 'F', 'p', 'eta_sq')
DEFAULT_LEVELS = 10
#: How time and samples enter (see the module docstring); 'levels' writes anova_*.csv.
VARIANTS = ('levels', 'samples', 'medians', 'covariate')
DEFAULT_VARIANT = 'levels'
VARIANT_TEXT = {
    'levels': 'one sample per episode at each of the time levels; time categorical',
    'samples': 'every sample after t = 0; time categorical, each sample in the time level '
               'whose interval it falls in',
    'medians': 'the median over seeds per cell and time level; time categorical',
    'covariate': 'one sample per episode at each of the time levels; time numeric (linear, '
                 '1 df)',
}


def _episode_keys(table: pd.DataFrame) -> list[str]:
    """The columns that name an episode: population, speed, seed and any design factor."""
    return ['population', 'speed', 'seed', *design_factors(table)]


def time_levels(table: pd.DataFrame, levels: int = DEFAULT_LEVELS) -> np.ndarray:
    """The sample times the ANOVA uses: ``levels`` evenly spaced times after 0, ending at the
    shortest episode's last sample, each snapped to the nearest sampled time."""
    end = table.groupby(_episode_keys(table))['t'].max().min()
    sampled = np.unique(table['t'])
    wanted = end * np.arange(1, levels + 1) / levels
    return np.unique(sampled[np.abs(sampled[None, :] - wanted[:, None]).argmin(axis=1)])


def anova_sample(table: pd.DataFrame, response: str, levels: int = DEFAULT_LEVELS,
                 variant: str = DEFAULT_VARIANT) -> pd.DataFrame:
    """The observations the ANOVA of ``response`` uses (columns: time, population, speed,
    the design factors and ``response``), per ``variant`` (:data:`VARIANTS`)."""
    if variant not in VARIANTS:
        raise ValueError(f'ANOVA variant must be one of {", ".join(VARIANTS)}, not {variant!r}')
    extra = design_factors(table)
    columns = ['t', 'population', 'speed', *extra, response]
    times = time_levels(table, levels)
    if variant == 'samples':
        # Every sample after t = 0 (up to the last level), labelled with the level that ends
        # its interval: the same 10 time levels, 400 times the observations.
        rows = table[(table['t'] > 0) & (table['t'] <= times[-1])][columns].copy()
        rows['t'] = times[np.searchsorted(times, rows['t'].to_numpy(), side='left')]
    else:
        rows = table[table['t'].isin(times)][columns]
    if variant == 'medians':
        rows = rows.groupby(['t', 'population', 'speed', *extra],
                            as_index=False)[response].median()
    sample = rows.rename(columns={'t': 'time'})
    return sample.dropna(subset=[response]).reset_index(drop=True)


def _term(name: str, variant: str) -> str:
    """The formula term of a factor: categorical (quoted, as design factors are dotted
    parameter keys), except time as a covariate."""
    if name == 'time' and variant == 'covariate':
        return 'time'
    return f"C(Q('{name}'))"


def anova(table: pd.DataFrame, response: str, levels: int = DEFAULT_LEVELS,
          variant: str = DEFAULT_VARIANT) -> pd.DataFrame:
    """Main-effects ANOVA of ``response`` on time, population, speed and the design factors.

    Args:
        table: the study's tidy table (columns population, speed, seed, t, ``response`` and
            any design factor, :func:`swarm_supervisor.study.table.design_factors`).
        levels: how many time levels to sample (see the module docstring).
        variant: how time and samples enter, one of :data:`VARIANTS` (module docstring).

    Returns:
        One row per factor (time, population, speed, then the design factors) and one for the
        residual, columns :data:`TABLE_COLUMNS`: the number of levels, degrees of freedom, sum
        of squares, F, p and eta squared (the factor's share of the total sum of squares). A
        factor with a single level in the data cannot be tested and gets NaN F and p.

    Raises:
        ValueError: an unknown variant, or too few observations to fit the model.
    """
    sample = anova_sample(table, response, levels, variant)
    factors = [*FACTORS, *design_factors(table)]
    counts = {name: sample[name].nunique() for name in factors}
    tested = [name for name in factors if counts[name] > 1]
    if not tested:
        raise ValueError(f'ANOVA of {response}: no factor has more than one level')
    formula = f"Q('{response}') ~ " + ' + '.join(_term(name, variant) for name in tested)
    model_df = sum(1 if _term(name, variant) == 'time' else counts[name] - 1
                   for name in tested)
    dof = len(sample) - 1 - model_df
    if dof < 1:
        raise ValueError(f'ANOVA of {response}: {len(sample)} observations leave no residual '
                         'degrees of freedom (add seeds or time levels)')
    # statsmodels (and the scipy it imports) cost about 2 s of CPU to import: only here, where
    # a model is fitted, not in every process that writes a report or reads a table.
    import statsmodels.formula.api as smf
    from statsmodels.stats.anova import anova_lm

    result = anova_lm(smf.ols(formula, data=sample).fit(), typ=2)
    total = float(((sample[response] - sample[response].mean()) ** 2).sum())
    rows = []
    for name in factors:
        if name in tested:
            line = result.loc[_term(name, variant)]
            rows.append({'factor': name, 'levels': counts[name], 'df': int(line['df']),
                         'sum_sq': line['sum_sq'], 'F': line['F'], 'p': line['PR(>F)']})
        else:
            rows.append({'factor': name, 'levels': counts[name], 'df': 0, 'sum_sq': 0.0,
                         'F': np.nan, 'p': np.nan})
    residual = result.loc['Residual']
    rows.append({'factor': 'residual', 'levels': np.nan, 'df': int(residual['df']),
                 'sum_sq': residual['sum_sq'], 'F': np.nan, 'p': np.nan})
    frame = pd.DataFrame(rows, columns=TABLE_COLUMNS[:-1])
    frame['eta_sq'] = frame['sum_sq'] / total if total > 0 else np.nan
    return frame


def compare_variants(table: pd.DataFrame, response: str, levels: int = DEFAULT_LEVELS,
                     variants: Sequence[str] = VARIANTS) -> pd.DataFrame:
    """F of each factor under each variant: one row per factor, one column per variant
    (NaN where a factor has one level, and for every factor of a variant that leaves too few
    observations to fit, e.g. medians over seeds of a small design), plus each variant's
    number of observations as the row 'observations'."""
    unknown = [variant for variant in variants if variant not in VARIANTS]
    if unknown:
        raise ValueError(f'variant must be one of {", ".join(VARIANTS)}, not {unknown[0]!r}')
    columns = {}
    for variant in variants:
        try:
            result = anova(table, response, levels, variant).set_index('factor')
        except ValueError:  # this variant cannot be fitted on this table: a column of NaN
            columns[variant] = pd.Series(dtype=float)
            continue
        column = result['F'].drop('residual')
        column['observations'] = float(result['df'].sum() + 1)
        columns[variant] = column
    return pd.DataFrame(columns).rename_axis('factor').reset_index()


def write_anova(frame: pd.DataFrame, path: str | Path) -> None:
    """Write an ANOVA table as CSV (columns :data:`TABLE_COLUMNS`)."""
    frame.to_csv(path, index=False, columns=list(TABLE_COLUMNS))
