"""Table 2's speed effect in robots: what the mean cue's SS_speed / SS_population says.

In a balanced main-effects ANOVA (table 2's layout: every population at every speed, as many
observations in each cell) a factor's sum of squares is its marginal one: SS_speed =
n_v sum_v (m_v - m)^2 and SS_population = n_N sum_N a_N^2, where m_x is the mean of the n_x
observations at level x, m the grand mean and a_N = m_N - m the population effects. With two
speeds the speed effect is one number, d = m_slow - m_fast (the cue a slower swarm leaves in
addition), and SS_speed = n_v d^2 / 2. The additive model the ANOVA fits predicts the cell
(N, v) as m + a_N + b_v, so the largest population at the slow speed performs like the
population N* at the fast speed whose effect is a_N* = a_Nmax + d (a_N interpolated linearly
between the design's populations): "N = 50 at 4 cm/s performs like N = N* at 8 cm/s".

The paper gives only F values (table 2: speed 67.1 on 1 df, population 39.4 on 4 df; both
share the residual, so SS_speed / SS_population = 67.1 / (4 x 39.4) = 0.426 whatever the
time coding). Which N* that ratio means depends on the shape of the population effect: the
speed difference it needs is d = sqrt(2 ratio n_N sum a_N^2 / n_v), found here for a study's
own population effects and for effects linear in N.

:func:`power_law_ratio` asks the converse for a swarm whose cleaning rate grows as
N^a v^b (the cue decaying as exp(-k N^a v^b t), k set so that a given cell halves the cue at
a given time): doubling the speed is then worth 2^(b/a) times the robots, and the ratio
follows.

    python -m swarm_supervisor.analysis.speed_effect results/study/all_metrics.csv
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from collections.abc import Sequence

import numpy as np
import pandas as pd

from swarm_supervisor.analysis.anova import anova_sample

#: Table 2 of the paper: F of the mean cue's population and speed, and their degrees of
#: freedom (five populations, two speeds).
PAPER_F = {'population': 39.383, 'speed': 67.144}
PAPER_DF = {'population': 4, 'speed': 1}
#: Fig. 4a: N = 30 at 8 cm/s has halved the cue by 1500 s; and a halving time so long that
#: the swarm barely cleans (the limit :func:`power_law_ratio` approaches).
FIG4_HALVING = 1500.0
BARELY_CLEANS = 1e12
#: The paper's SS_speed / SS_population of the mean cue (0.426).
PAPER_RATIO = PAPER_F['speed'] * PAPER_DF['speed'] / (PAPER_F['population'] *
                                                      PAPER_DF['population'])


@dataclasses.dataclass(frozen=True)
class SpeedEffect:
    """A study's speed effect on the mean cue, in cue units and in robots."""

    ratio: float  #: SS_speed / SS_population
    difference: float  #: d: mean at the slowest speed minus mean at the fastest (cue units)
    effects: pd.Series  #: a_N, the population effects (cue units), indexed by N
    slow: float  #: the slowest speed (m/s)
    fast: float  #: the fastest speed (m/s)
    like: float  #: N*: the largest population at the slow speed performs like N* at the fast
    needed_like: float  #: N* if the ratio were the target, with these population effects
    needed_like_linear: float  #: the same with population effects linear in N
    target: float  #: the ratio ``needed_like`` is for (the paper's)

    @property
    def top(self) -> int:
        """The largest population of the design."""
        return int(self.effects.index.max())


def equivalent_population(effects: pd.Series, shift: float) -> float:
    """The population whose effect is the largest population's plus ``shift``, linearly
    interpolated between the design's populations (NaN when it lies outside them)."""
    effects = effects.sort_index()
    wanted = float(effects.iloc[-1]) + shift
    populations = effects.index.to_numpy(dtype=float)
    values = effects.to_numpy(dtype=float)
    for i in range(len(values) - 1, 0, -1):  # from the largest population down
        low, high = sorted((values[i - 1], values[i]))
        if low <= wanted <= high and values[i - 1] != values[i]:
            share = (wanted - values[i]) / (values[i - 1] - values[i])
            return float(populations[i] + share * (populations[i - 1] - populations[i]))
    return float(populations[-1]) if shift == 0 else math.nan


def speed_effect(table: pd.DataFrame, response: str = 'mean_cue',
                 target: float = PAPER_RATIO) -> SpeedEffect:
    """The speed effect of a study's tidy table (the observations of table 2's ANOVA,
    :func:`~swarm_supervisor.analysis.anova.anova_sample`).

    Raises:
        ValueError: not two speeds and at least two populations, or cells of unequal size
            (the marginal sums of squares are table 2's only in a balanced design).
    """
    sample = anova_sample(table, response)
    speeds = sorted(sample['speed'].unique())
    counts = sample.groupby(['population', 'speed']).size()
    if len(speeds) != 2 or sample['population'].nunique() < 2:
        raise ValueError('the speed effect needs two speeds and at least two populations')
    if counts.nunique() != 1 or len(counts) != sample['population'].nunique() * 2:
        raise ValueError('the speed effect needs a balanced design (every population at '
                         'both speeds, as many observations in each cell)')
    grand = sample[response].mean()
    by_speed = sample.groupby('speed')[response].mean()
    effects = sample.groupby('population')[response].mean() - grand
    n_speed = len(sample) / 2
    n_population = len(sample) / len(effects)
    difference = float(by_speed[speeds[0]] - by_speed[speeds[1]])
    ss_speed = n_speed * float(((by_speed - grand) ** 2).sum())
    ss_population = n_population * float((effects ** 2).sum())
    needed = math.sqrt(2 * target * n_population * float((effects ** 2).sum()) / n_speed)
    populations = effects.index.to_numpy(dtype=float)
    spread = float(((populations - populations.mean()) ** 2).sum())
    needed_linear = populations.max() - math.sqrt(2 * target * n_population * spread
                                                  / n_speed)
    return SpeedEffect(ratio=ss_speed / ss_population if ss_population > 0 else math.nan,
                       difference=difference, effects=effects,
                       slow=float(speeds[0]), fast=float(speeds[1]),
                       like=equivalent_population(effects, difference),
                       needed_like=equivalent_population(effects, needed),
                       needed_like_linear=float(needed_linear), target=target)


def power_law_ratio(a: float, b: float, *, populations: Sequence[int] = (10, 20, 30, 40, 50),
                    speeds: Sequence[float] = (0.04, 0.08), duration: float = 4000.0,
                    levels: int = 10, halves: tuple[int, float, float] = (30, 0.08, 1500.0)
                    ) -> float:
    """SS_speed / SS_population of the mean cue in table 2's design (``levels`` time levels
    of an episode of ``duration``) for a cue that decays as exp(-k N^a v^b t), k such that the
    cell ``halves`` = (N, v, t) has half its cue left at t (a t of, say, 1e12 s gives the
    limit of a swarm that barely cleans)."""
    n = np.asarray(populations, dtype=float)[:, None, None]
    v = np.asarray(speeds, dtype=float)[None, :, None]
    t = duration * np.arange(1, levels + 1)[None, None, :] / levels
    population, speed, at = halves
    k = math.log(2) / (at * population ** a * speed ** b)
    cleaned = -np.expm1(-k * n ** a * v ** b * t)  # 1 - the cue left, exact when tiny
    grand = cleaned.mean()
    ss_speed = cleaned.shape[0] * levels * float(((cleaned.mean(axis=(0, 2)) - grand) ** 2)
                                                 .sum())
    ss_population = cleaned.shape[1] * levels * float(((cleaned.mean(axis=(1, 2)) - grand)
                                                       ** 2).sum())
    return ss_speed / ss_population


def power_law_speed_worth(target: float = PAPER_RATIO, a: float = 1.0,
                          halving: float = FIG4_HALVING) -> float:
    """The exponent b for which :func:`power_law_ratio` (a, b) is ``target`` when N = 30 at
    8 cm/s halves the cue at ``halving`` s: doubling the speed is then worth 2^(b/a) times
    the robots."""
    from scipy.optimize import brentq

    return float(brentq(lambda b: power_law_ratio(a, b, halves=(30, 0.08, halving))
                        - target, 0.0, 6.0 * a))


def describe(effect: SpeedEffect) -> str:
    """One sentence for report.md."""
    slow, fast = (f'{speed * 100:g} cm/s' for speed in (effect.slow, effect.fast))

    def robots(value: float) -> str:
        return f'{value:.1f}' if math.isfinite(value) else 'below the smallest population'

    return (f'Speed in robots (table 2): SS_speed / SS_population of the mean cue is '
            f'{effect.ratio:.3f} (the paper: {effect.target:.3f}); by the main effects, '
            f'N = {effect.top} at {slow} performs like N = {robots(effect.like)} at {fast}, '
            f"where the paper's ratio would need N = {robots(effect.needed_like)} with this "
            f"study's population effects (N = {robots(effect.needed_like_linear)} with "
            'effects linear in N; docs/reproduction.md).')


#: The cleaning regimes :func:`regime_table` prints: name, a, b (cleaning rate ~ N^a v^b).
REGIMES = (('taxis-limited, speed changes nothing at the source', 1.0, 0.0),
           ('encounter-limited, dilute (pairs of moving robots)', 2.0, 1.0),
           ('encounter-limited, waiting robots drawing more encounters', 3.0, 1.0),
           ('between the two', 1.5, 1.0),
           ('each robot cleans alone as it drives', 1.0, 1.0))


def regime_table() -> list[str]:
    """As Markdown lines: the ratio of each cleaning regime (:data:`REGIMES`) when N = 30 at
    8 cm/s halves the cue at 1500 s and when the swarm barely cleans; then what the paper's
    ratio needs a doubled speed to be worth, for a = 1, 2, 3."""
    halving, barely = ((30, 0.08, FIG4_HALVING), (30, 0.08, BARELY_CLEANS))
    lines = ['| cleaning rate ~ | N = 50 at 4 cm/s performs like N at 8 cm/s | '
             'SS_speed / SS_population, N = 30 at 8 cm/s halving the cue at 1500 s | '
             'the same, as the cleaning vanishes |', '|---|---|---|---|']
    for name, a, b in REGIMES:
        lines.append(f'| {name}: N^{a:g} v^{b:g} | {50 * 2 ** (-b / a):.1f} | '
                     f'{power_law_ratio(a, b, halves=halving):.3f} | '
                     f'{power_law_ratio(a, b, halves=barely):.3f} |')
    lines += ['', f"| the paper's {PAPER_RATIO:.3f} needs, with cleaning rate ~ N^a v^b | "
              'a = 1 | a = 2 | a = 3 |', '|---|---|---|---|']
    for label, at in (('N = 30 at 8 cm/s halving the cue at 1500 s', FIG4_HALVING),
                      ('as the cleaning vanishes', BARELY_CLEANS)):
        cells = []
        for a in (1.0, 2.0, 3.0):
            b = power_law_speed_worth(a=a, halving=at)
            cells.append(f'N = {50 * 2 ** (-b / a):.1f} (speed worth x {2 ** (b / a):.2f})')
        lines.append(f'| {label} | ' + ' | '.join(cells) + ' |')
    return lines


def main(argv: list[str] | None = None) -> int:
    """Print a study's speed effect and the ratio of each cleaning regime."""
    parser = argparse.ArgumentParser(
        prog='python -m swarm_supervisor.analysis.speed_effect',
        description="Table 2's speed effect in robots, from a study's all_metrics.csv.")
    parser.add_argument('table', help="a study's all_metrics.csv")
    args = parser.parse_args(argv)
    from swarm_supervisor.study import read_table

    try:
        effect = speed_effect(read_table(args.table))
    except (OSError, ValueError) as error:
        print(f'speed_effect: error: {error}', file=sys.stderr)
        return 2
    print(describe(effect))
    print()
    print('\n'.join(regime_table()))
    return 0


if __name__ == '__main__':
    sys.exit(main())
