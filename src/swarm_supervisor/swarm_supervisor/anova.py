"""Tables 2 and 3: ANOVA of the mean cue and of coherency with time, population and speed.

How time enters: every episode contributes one observation per *time level*, its value at
t = D/k, 2D/k, ..., D (D the episode length, k = ``levels``, 10 by default: every 400 s in
the paper's 4000 s episodes). Time, population and speed are categorical factors of a
main-effects linear model fitted by ordinary least squares (statsmodels ``ols``), tested with
type-II sums of squares (``anova_lm(typ=2)``). t = 0 is left out: every episode starts from
the same cue, so it carries no information about the factors. Sampling sparsely keeps the
table small and limits the autocorrelation between an episode's successive samples; the
observations of one episode are still not independent, so p-values, most of all time's, are
optimistic (as in any ANOVA that treats repeated measures as independent).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import statsmodels.formula.api as smf
from statsmodels.stats.anova import anova_lm

#: The factors, as the tables name them ('time' is the tidy table's column t).
FACTORS = ('time', 'population', 'speed')
TABLE_COLUMNS = ('factor', 'levels', 'df', 'sum_sq', 'F', 'p', 'eta_sq')
DEFAULT_LEVELS = 10


def time_levels(table: pd.DataFrame, levels: int = DEFAULT_LEVELS) -> np.ndarray:
    """The sample times the ANOVA uses: ``levels`` evenly spaced times after 0, ending at the
    shortest episode's last sample, each snapped to the nearest sampled time."""
    end = table.groupby(['population', 'speed', 'seed'])['t'].max().min()
    sampled = np.unique(table['t'])
    wanted = end * np.arange(1, levels + 1) / levels
    return np.unique(sampled[np.abs(sampled[None, :] - wanted[:, None]).argmin(axis=1)])


def anova_sample(table: pd.DataFrame, response: str,
                 levels: int = DEFAULT_LEVELS) -> pd.DataFrame:
    """The observations the ANOVA of ``response`` uses: one per episode and time level."""
    times = time_levels(table, levels)
    rows = table[table['t'].isin(times)]
    sample = rows[['t', 'population', 'speed', response]].rename(columns={'t': 'time'})
    return sample.dropna(subset=[response]).reset_index(drop=True)


def anova(table: pd.DataFrame, response: str, levels: int = DEFAULT_LEVELS) -> pd.DataFrame:
    """Main-effects ANOVA of ``response`` on time, population and speed (all categorical).

    Args:
        table: the study's tidy table (columns population, speed, seed, t and ``response``).
        levels: how many time levels to sample (see the module docstring).

    Returns:
        One row per factor and one for the residual, columns :data:`TABLE_COLUMNS`: the number
        of levels, degrees of freedom, sum of squares, F, p and eta squared (the factor's share
        of the total sum of squares). A factor with a single level in the data cannot be tested
        and gets NaN F and p.

    Raises:
        ValueError: the table has too few observations to fit the model.
    """
    sample = anova_sample(table, response, levels)
    counts = {name: sample[name].nunique() for name in FACTORS}
    tested = [name for name in FACTORS if counts[name] > 1]
    if not tested:
        raise ValueError(f'ANOVA of {response}: no factor has more than one level')
    formula = f'{response} ~ ' + ' + '.join(f'C({name})' for name in tested)
    dof = len(sample) - 1 - sum(counts[name] - 1 for name in tested)
    if dof < 1:
        raise ValueError(f'ANOVA of {response}: {len(sample)} observations leave no residual '
                         'degrees of freedom (add seeds or time levels)')
    result = anova_lm(smf.ols(formula, data=sample).fit(), typ=2)
    total = float(((sample[response] - sample[response].mean()) ** 2).sum())
    rows = []
    for name in FACTORS:
        if name in tested:
            line = result.loc[f'C({name})']
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


def write_anova(frame: pd.DataFrame, path: str | Path) -> None:
    """Write an ANOVA table as CSV (columns :data:`TABLE_COLUMNS`)."""
    frame.to_csv(path, index=False, columns=list(TABLE_COLUMNS))
