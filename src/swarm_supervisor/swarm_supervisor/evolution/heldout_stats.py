"""The held-out comparison's statistics, behaviour table and figure (:mod:`.heldout`).

- **Paired tests.** For each scenario and each pair [a, b] of the plan, on the same seeds:
  the Wilcoxon signed-rank test (scipy, two-sided, zero differences dropped) of a's scores
  against b's, on the fitness (the mean cue fraction over the episode, lower is better) and
  on the cue left at the end. The p-values of all tests of a comparison form one family and
  are adjusted by Holm's step-down method (S. Holm, "A simple sequentially rejective
  multiple test procedure", Scand. J. Statist. 6:65-70, 1979; statsmodels'
  ``multipletests(method='holm')``), which controls the family-wise error rate.
- **Effect sizes.** The median paired difference a - b, the seeds where a is lower (better),
  and the matched-pairs rank-biserial correlation r = (R+ - R-) / (R+ + R-), R+ and R- the
  rank sums of the positive and negative differences (ranks of |a - b|, zeros dropped, ties
  averaged; D. S. Kerby, "The simple difference formula", Compr. Psychol. 3, 2014): -1 when
  a is lower on every seed, +1 when it is higher on every one.
- **Behaviour** (:mod:`.behaviour`): the first ``behaviour_seeds`` seeds of every
  (scenario, controller), averaged.
- **Figure**: the cue left at the end against ``world.cleaning_quorum`` k, for each
  controller, over the plan's ``figure`` scenarios (median and quartiles over the seeds).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from swarm_supervisor.evolution.heldout import Plan, episode_config, read_chunk

#: The two scores compared.
METRICS = ('fitness', 'final')
#: The behaviour measures tabulated (evolution.behaviour).
BEHAVIOUR = ('cleaner_on', 'removed_per_tick', 'cleaning_beside_robot', 'distance',
             'forward_speed')


def rank_biserial(a: list[float], b: list[float]) -> float:
    """The matched-pairs rank-biserial correlation of a - b (0 if every pair ties)."""
    from scipy.stats import rankdata

    difference = np.subtract(a, b)
    difference = difference[difference != 0]
    if not len(difference):
        return 0.0
    ranks = rankdata(np.abs(difference))
    plus, minus = ranks[difference > 0].sum(), ranks[difference < 0].sum()
    return float((plus - minus) / (plus + minus))


def paired(a: list[float], b: list[float]) -> dict[str, Any]:
    """a against b on the same seeds: means, medians, the median difference, a's wins, the
    Wilcoxon statistic and p-value (None if every pair ties) and the rank-biserial r."""
    from scipy.stats import wilcoxon

    difference = np.subtract(a, b)
    test = wilcoxon(a, b) if np.any(difference) else None
    return {'a_mean': math.fsum(a) / len(a), 'b_mean': math.fsum(b) / len(b),
            'a_median': float(np.median(a)), 'b_median': float(np.median(b)),
            'median_difference': float(np.median(difference)),
            'a_lower': int(np.sum(difference < 0)), 'seeds': len(a),
            'wilcoxon_statistic': None if test is None else float(test.statistic),
            'p_value': None if test is None else float(test.pvalue),
            'rank_biserial': rank_biserial(a, b)}


def holm(p_values: list[float]) -> list[float]:
    """Holm's adjusted p-values, in the order given."""
    from statsmodels.stats.multitest import multipletests

    return [float(p) for p in multipletests(p_values, method='holm')[1]]


def summarise(plan: Plan, out: Path) -> dict[str, Any]:
    """Per scenario: each controller's means and medians, and every pair's tests (with
    Holm's adjusted p over the whole family); the chunks that have not run are left out."""
    summary: dict[str, Any] = {}
    tests = []
    for scenario in plan.scenarios:
        chunks = {name: read_chunk(out, scenario, name) for name in plan.controllers}
        done = {name: chunk for name, chunk in chunks.items() if chunk is not None}
        entry: dict[str, Any] = {'controllers': {
            name: {f'{metric}_{stat}': float(fn(chunk[metric])) for metric in METRICS
                   for stat, fn in (('mean', np.mean), ('median', np.median),
                                    ('q1', lambda v: np.percentile(v, 25)),
                                    ('q3', lambda v: np.percentile(v, 75)))}
            for name, chunk in done.items()}, 'pairs': {}}
        for a, b in plan.pairs:
            if a in done and b in done:
                assert done[a]['seed'] == done[b]['seed'], 'chunks of other seeds'
                result = {metric: paired(done[a][metric], done[b][metric])
                          for metric in METRICS}
                entry['pairs'][f'{a} vs {b}'] = result
                tests += [result[metric] for metric in METRICS
                          if result[metric]['p_value'] is not None]
        summary[scenario] = entry
    for test, adjusted in zip(tests, holm([t['p_value'] for t in tests]) if tests else []):
        test['p_holm'] = adjusted
    return summary


def behaviour_table(plan: Plan, out: Path, pool: Any | None) -> dict[str, Any]:
    """Each (scenario, controller)'s behaviour over the first ``behaviour_seeds`` seeds,
    averaged (cached in ``behaviour.json``: a pair already measured is not run again)."""
    from swarm_supervisor.evolution.behaviour import behaviour

    path = out / 'behaviour.json'
    table = json.loads(path.read_text()) if path.exists() else {}
    seeds = plan.seeds[:plan.behaviour_seeds]
    for scenario in plan.scenarios:
        for controller in plan.controllers:
            key = f'{scenario}.{controller}'
            if key in table:
                continue
            configs = [episode_config(plan, scenario, controller, seed) for seed in seeds]
            rows = pool.map(behaviour, configs, chunksize=1) if pool is not None else \
                [behaviour(config) for config in configs]
            table[key] = {name: math.fsum(row[name] for row in rows) / len(rows)
                          for name in rows[0]}
            path.write_text(json.dumps(table, indent=2) + '\n')
    return table


def figure(plan: Plan, out: Path) -> Path | None:
    """cue_vs_k.png: the cue left at the end against k, a line per controller."""
    if not plan.figure:
        return None
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, axis = plt.subplots(figsize=(5.5, 3.8))
    ks = [plan.scenarios[name][0].replace(world=plan.scenarios[name][1]).world.cleaning_quorum
          for name in plan.figure]
    for offset, controller in enumerate(plan.controllers):
        chunks = [read_chunk(out, scenario, controller) for scenario in plan.figure]
        if any(chunk is None for chunk in chunks):
            continue
        finals = [chunk['final'] for chunk in chunks if chunk is not None]
        x = np.array(ks, dtype=float) + 0.06 * (offset - (len(plan.controllers) - 1) / 2)
        median = [np.median(v) for v in finals]
        low = [m - np.percentile(v, 25) for m, v in zip(median, finals)]
        high = [np.percentile(v, 75) - m for m, v in zip(median, finals)]
        axis.errorbar(x, median, yerr=[low, high], marker='o', capsize=3, label=controller)
    axis.set_xticks(ks)
    axis.set_xlabel('robots a cleaning group needs, k (world.cleaning_quorum)')
    axis.set_ylabel('cue left at the end (fraction of the initial)')
    axis.legend(fontsize=8)
    fig.tight_layout()
    path = out / 'cue_vs_k.png'
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
