"""A trial's score: the paper's claims checked on its table, and its ratio of the mean cue's
sums of squares for speed and population beside the paper's."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import pandas as pd

from swarm_supervisor.analysis import anova as anova_tables
from swarm_supervisor.analysis.checks import evaluate
from swarm_supervisor.analysis.claims import HOLDS, Claim
from swarm_supervisor.calibration.design import Objective

#: The loss of a ratio that cannot be formed (no speed or population effect at all): as far
#: off as three decades.
NO_RATIO_DECADES = 3.0


@dataclasses.dataclass(frozen=True)
class Score:
    """How a trial's studies compare with the paper."""

    held: tuple[str, ...]  #: the claims that hold
    failed: tuple[str, ...]  #: the claims that do not hold (or are not applicable)
    ratio: float  #: SS_speed / SS_population of the mean cue (table 2's layout)
    f_values: dict[str, float]  #: F of time, population and speed in that ANOVA
    loss: float  #: failed claims + weight x decades off the ratio target

    def as_row(self) -> dict[str, object]:
        """The score's columns of trials.csv."""
        return {'loss': self.loss, 'claims_held': len(self.held),
                'claims': len(self.held) + len(self.failed), 'ratio': self.ratio,
                **{f'F_{name}': value for name, value in self.f_values.items()},
                'failed': ' '.join(self.failed)}


def speed_population_ratio(table: pd.DataFrame) -> tuple[float, dict[str, float]]:
    """The mean cue's SS_speed / SS_population (NaN when either is 0 or not tested) and F of
    each factor, from the ANOVA of table 2 (:func:`swarm_supervisor.analysis.anova.anova`)."""
    frame = anova_tables.anova(table, 'mean_cue').set_index('factor')
    f_values = {name: float(frame.loc[name, 'F']) for name in anova_tables.FACTORS}
    speed, population = (float(frame.loc[name, 'sum_sq']) for name in ('speed', 'population'))
    ratio = speed / population if speed > 0 and population > 0 else math.nan
    return ratio, f_values


def score(table: pd.DataFrame, claims: Sequence[Claim], objective: Objective) -> Score:
    """Check ``claims`` on a trial's tidy table and form its loss (see :class:`Objective`)."""
    results = evaluate(table, claims)
    held = tuple(r.id for r in results if r.status == HOLDS)
    failed = tuple(r.id for r in results if r.status != HOLDS)
    ratio, f_values = speed_population_ratio(table)
    decades = (abs(math.log10(ratio / objective.ratio_target)) if ratio > 0
               else NO_RATIO_DECADES)
    return Score(held, failed, ratio, f_values,
                 len(failed) + objective.ratio_weight * min(decades, NO_RATIO_DECADES))
