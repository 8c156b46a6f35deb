"""The decision x claim matrix of a one-at-a-time sweep, on synthetic tables whose verdicts
are known: a claim that holds at the base and fails under one level is marked changed."""

from __future__ import annotations

import numpy as np
import pandas as pd

from swarm_supervisor.analysis import claims, sensitivity
from swarm_supervisor.analysis.figures import BASE_LABEL

MORE_ROBOTS = claims.parse_claims({'claims': [{
    'id': 'more-robots', 'where': 'fig. 4a', 'paper': 'More robots clean faster.',
    'check': {'kind': 'order', 'metric': 'mean_cue_fraction', 'across': 'population',
              'at': ['end'], 'direction': 'decreasing'}}]})


def episode(population: int, seed: int, rate: float, **factors) -> pd.DataFrame:
    t = np.arange(0.0, 101.0)
    fraction = np.exp(-rate * t)
    return pd.DataFrame({'population': population, 'speed': 0.08, 'seed': seed, **factors,
                         't': t, 'mean_cue': 40 * fraction, 'mean_cue_fraction': fraction,
                         'ratio_near_source': 0.5, 'coherency': 1.0})


def sweep_table() -> pd.DataFrame:
    """Base (ir_range 0.03, monotone): N = 50 cleans faster. Under ir_range = 0.06 the order
    reverses; under cleaning = literal it holds."""
    frames = []
    cells = [({'mona.ir_range': 0.03, 'world.cleaning': 'monotone'}, False),
             ({'mona.ir_range': 0.06, 'world.cleaning': 'monotone'}, True),
             ({'mona.ir_range': 0.03, 'world.cleaning': 'literal'}, False)]
    for factors, reversed_order in cells:
        for seed in (1, 2, 3):
            for population, rate in ((10, 0.01), (50, 0.02)):
                if reversed_order:
                    rate = 0.03 - rate
                frames.append(episode(population, seed, rate + 0.0001 * seed, **factors))
    return pd.concat(frames, ignore_index=True)


def test_matrix_marks_the_level_that_changes_a_claim():
    matrix = sensitivity.claim_matrix(sweep_table(), MORE_ROBOTS)
    assert list(matrix['variant']) == [BASE_LABEL, 'world.cleaning = literal',
                                       'mona.ir_range = 0.06']  # the base first
    assert list(matrix['more-robots']) == [claims.HOLDS, claims.HOLDS, claims.FAILS]
    flags = sensitivity.changed(matrix)
    assert list(flags['more-robots']) == [False, False, True]
    text = sensitivity.render(matrix, MORE_ROBOTS)
    assert '| mona.ir_range = 0.06 | **fails** | 1 |' in text
    assert '| world.cleaning = literal | holds | 0 |' in text


def test_not_applicable_never_counts_as_a_change():
    table = sweep_table()
    # The literal variant loses N = 50: nothing to order there.
    table = table[~((table['world.cleaning'] == 'literal') & (table['population'] == 50))]
    matrix = sensitivity.claim_matrix(table, MORE_ROBOTS)
    assert matrix.loc[1, 'variant'] == 'world.cleaning = literal'
    assert matrix.loc[1, 'more-robots'] == claims.NOT_APPLICABLE
    assert not sensitivity.changed(matrix).loc[1, 'more-robots']


def test_written_only_for_a_design_with_factors(tmp_path):
    assert sensitivity.write_sensitivity(tmp_path, sweep_table(), MORE_ROBOTS) is not None
    assert pd.read_csv(tmp_path / sensitivity.MATRIX_CSV).shape == (3, 2)
    plain = sweep_table().query("`world.cleaning` == 'monotone' and `mona.ir_range` == 0.03")
    plain = plain.drop(columns=['mona.ir_range', 'world.cleaning'])
    assert sensitivity.write_sensitivity(tmp_path, plain, MORE_ROBOTS) is None
    assert not (tmp_path / sensitivity.MATRIX_MD).exists()  # the stale matrix is gone
