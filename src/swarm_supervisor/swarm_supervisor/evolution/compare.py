"""The post-evaluation: the best genome against BEECLUST on the same held-out seeds.

For each scenario (a parameter file of ``evolve.compare``, else the design's own), both
controllers run ``held_out`` episodes of the design's N and duration on the same seeds,
drawn from the design's seed on a stream of their own and never a training seed. The score
is the evolution's fitness (the episode's mean cue fraction, lower is better); a paired
Wilcoxon signed-rank test (scipy) compares them per scenario. Writes ``compare.csv`` (one
row per scenario and seed), ``compare.json`` (per scenario: means, medians, the median paired
difference, wins, the statistic and p-value, and both controllers' behaviour on the first
seed, :mod:`swarm_supervisor.evolution.behaviour`) and ``compare.png``.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from swarm_supervisor.config import SwarmConfig, load_config
from swarm_supervisor.evolution.behaviour import behaviour
from swarm_supervisor.evolution.design import Design
from swarm_supervisor.evolution.fitness import genome_config, run_scores, training_seeds


def held_out_seeds(design: Design) -> list[int]:
    """``held_out`` seeds of their own stream, none of them a training seed."""
    training = {seed for generation in range(design.generations)
                for seed in training_seeds(design, generation)}
    rng = np.random.default_rng([design.seed, 0x4E1D])
    seeds: list[int] = []
    while len(seeds) < design.held_out:
        seed = int(rng.integers(1, 2**31 - 1))
        if seed not in training and seed not in seeds:
            seeds.append(seed)
    return seeds


def scenario_configs(design: Design, base: SwarmConfig, weights: Path,
                     seeds: list[int]) -> tuple[list[SwarmConfig], list[SwarmConfig]]:
    """The BEECLUST episodes (the scenario's own controller section) and the network's."""
    network = dataclasses.replace(design, base=base)
    beeclust = [base.replace(episode={'population': design.robots,
                                      'duration': design.duration, 'seed': seed},
                             controller={'kind': 'beeclust'}) for seed in seeds]
    return beeclust, [genome_config(network, weights, seed) for seed in seeds]


def paired(beeclust: list[float], network: list[float]) -> dict[str, Any]:
    """The summary and paired Wilcoxon test of one scenario."""
    from scipy.stats import wilcoxon

    difference = np.subtract(network, beeclust)
    test = wilcoxon(network, beeclust) if np.any(difference) else None
    return {'episodes': len(beeclust),
            'beeclust_mean': math.fsum(beeclust) / len(beeclust),
            'network_mean': math.fsum(network) / len(network),
            'beeclust_median': float(np.median(beeclust)),
            'network_median': float(np.median(network)),
            'median_difference': float(np.median(difference)),
            'network_wins': int(np.sum(difference < 0)),
            'wilcoxon_statistic': None if test is None else float(test.statistic),
            'p_value': None if test is None else float(test.pvalue)}


def compare(design: Design, out: Path, pool: Any | None, jobs: int) -> dict[str, Any]:
    """Run the post-evaluation of ``out / 'best.npz'`` and write its files; the summary."""
    seeds = held_out_seeds(design)
    scenarios = list(design.compare) or [design.config or '']
    rows, summary = [], {}
    for scenario in scenarios:
        base = load_config(scenario or None)
        name = Path(scenario).stem if scenario else 'default'
        beeclust, network = scenario_configs(design, base, out / 'best.npz', seeds)
        # One kind per batch: a merged controller steps robots of one kind.
        theirs = run_scores(beeclust, design.batch, pool, jobs)
        ours = run_scores(network, design.batch, pool, jobs)
        summary[name] = paired(theirs, ours)
        # What each does, on the first held-out seed (evolution.behaviour).
        summary[name]['behaviour'] = {'beeclust': behaviour(beeclust[0]),
                                      'network': behaviour(network[0])}
        rows += [(name, seed, b, n) for seed, b, n in zip(seeds, theirs, ours)]
    with (out / 'compare.csv').open('w', newline='') as handle:
        writer = csv.writer(handle)
        writer.writerow(('scenario', 'seed', 'beeclust', 'network'))
        writer.writerows(rows)
    (out / 'compare.json').write_text(json.dumps(summary, indent=2) + '\n')
    figure(out, rows, summary)
    return summary


def figure(out: Path, rows: list[tuple[str, int, float, float]],
           summary: dict[str, Any]) -> Path:
    """compare.png: each scenario's scores of both controllers (boxes), p-value above."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    names = list(summary)
    fig, axes = plt.subplots(1, len(names), figsize=(3.2 * len(names), 3.5), squeeze=False)
    for axis, name in zip(axes[0], names):
        mine = [row for row in rows if row[0] == name]
        axis.boxplot([[r[2] for r in mine], [r[3] for r in mine]])
        axis.set_xticks([1, 2], ['BEECLUST', 'network'])
        p = summary[name]['p_value']
        axis.set_title(f'{name}\np = {p:.2g}' if p is not None else name, fontsize=9)
        axis.set_ylabel('mean cue fraction (lower is better)')
    fig.tight_layout()
    path = out / 'compare.png'
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
