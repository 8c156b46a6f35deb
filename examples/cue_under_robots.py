"""A metric of one's own: the mean cue under the robots (docs/extending.md, "A metric").

Name this module in ``MONA_SWARM_METRICS`` and every process that imports
``swarm_metrics.metrics`` registers it: metrics.csv gains the column, every bag its
``/metrics/cue_under_robots`` topic, ``analyze`` and the completeness checks the entry::

    PYTHONPATH=. MONA_SWARM_METRICS=examples.cue_under_robots \\
        mona-swarm run --population 10 --duration 60 --out results/mine --bag

Run as a script, it registers the metric in this process and prints the column of a short
episode.
"""

from __future__ import annotations

import numpy as np

from swarm_metrics.metrics import Metric, Sample, register


def cue_under_robots(sample: Sample) -> float:
    """The mean cue (0..255) in the raster cells under the robots' centres."""
    rows, cols = sample.cue.shape  # cue row i is y = (i + 0.5) * cell_size
    i = np.clip((sample.positions[:, 1] / sample.cell_size).astype(int), 0, rows - 1)
    j = np.clip((sample.positions[:, 0] / sample.cell_size).astype(int), 0, cols - 1)
    return float(sample.cue[i, j].mean(dtype=np.float64)) if len(i) else float('nan')


METRIC = register(Metric('cue_under_robots', 'cue units (0..255)',
                         'the mean cue under the robots', cue_under_robots,
                         'cue under the robots'))


def main() -> None:
    """A 60 s episode of 10 robots: the paper's mean cue beside the cue under the robots."""
    from swarm_supervisor.config import load_config
    from swarm_supervisor.engine import run_episode
    result = run_episode(load_config().replace(episode={'population': 10, 'duration': 60.0}))
    for row in result.metrics[::20]:
        print(f"t = {row['t']:4.0f} s: mean cue {row['mean_cue']:6.2f}, "
              f"under the robots {row['cue_under_robots']:6.2f}")


if __name__ == '__main__':
    main()
