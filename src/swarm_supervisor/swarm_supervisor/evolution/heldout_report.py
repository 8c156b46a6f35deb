"""report.md of a held-out comparison: its numbers as Markdown tables (:mod:`.heldout`)."""

from __future__ import annotations

from typing import Any

from swarm_supervisor.evolution.heldout import Plan
from swarm_supervisor.evolution.heldout_stats import BEHAVIOUR


def _p(value: float | None) -> str:
    return 'n/a' if value is None else f'{value:.2g}'


def report(plan: Plan, summary: dict[str, Any], behaviour: dict[str, Any]) -> str:
    """Three tables: scores per scenario and controller, the paired tests, the behaviour."""
    seeds = len(plan.seeds)
    lines = [f'# Held-out comparison ({seeds} seeds, N = {plan.robots}, {plan.duration:g} s)',
             '', 'Fitness: the mean cue fraction over the episode; final: the cue fraction '
             'at its end (lower is better). Median [quartiles].', '',
             '| scenario | controller | fitness mean | fitness median [q1, q3] | '
             'final mean | final median [q1, q3] |', '|---|---|---|---|---|---|']
    for scenario, entry in summary.items():
        for name, s in entry['controllers'].items():
            lines.append(f'| {scenario} | {name} | {s["fitness_mean"]:.3f} | '
                         f'{s["fitness_median"]:.3f} [{s["fitness_q1"]:.3f}, '
                         f'{s["fitness_q3"]:.3f}] | {s["final_mean"]:.3f} | '
                         f'{s["final_median"]:.3f} [{s["final_q1"]:.3f}, '
                         f'{s["final_q3"]:.3f}] |')
    lines += ['', 'Paired tests, a against b: median difference a - b, seeds where a is '
              'lower, matched-pairs rank-biserial r (-1: a lower on every seed), Wilcoxon '
              "p and Holm's adjusted p over every test here.", '',
              '| scenario | a vs b | score | median a - b | a lower | r | p | p (Holm) |',
              '|---|---|---|---|---|---|---|---|']
    for scenario, entry in summary.items():
        for pair, tests in entry['pairs'].items():
            for metric, t in tests.items():
                lines.append(f'| {scenario} | {pair} | {metric} | '
                             f'{t["median_difference"]:+.3f} | {t["a_lower"]} of '
                             f'{t["seeds"]} | {t["rank_biserial"]:+.2f} | '
                             f'{_p(t["p_value"])} | {_p(t.get("p_holm"))} |')
    if behaviour:
        lines += ['', f'Behaviour, the mean over the first {plan.behaviour_seeds} seeds: '
                  'time cleaning (share of robot-time with the cleaner on), cue removed per '
                  'cleaning tick (share of a full patch), share of cleaning with a robot in '
                  'view, distance travelled per robot, mean forward speed.', '',
                  '| scenario | controller | cleaning | removed per tick | beside a robot | '
                  'distance (m) | speed (cm/s) |', '|---|---|---|---|---|---|---|']
        for key, row in behaviour.items():
            scenario, _, name = key.partition('.')
            values = [row[m] for m in BEHAVIOUR]
            lines.append(f'| {scenario} | {name} | {values[0]:.1%} | {values[1]:.2f} | '
                         f'{values[2]:.0%} | {values[3]:.1f} | {100 * values[4]:.2f} |')
    return '\n'.join(lines) + '\n'
