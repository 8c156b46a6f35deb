"""The claims checks on synthetic tidy tables that make each hold and fail, and the claims
files: the shipped one loads, a bad claim is an error naming its id and field."""

import math
from collections.abc import Callable

import numpy as np
import pandas as pd
import pytest
import yaml

from swarm_supervisor.analysis import claims
from swarm_supervisor.analysis.checks import CHECKS, evaluate, evaluate_levels
from swarm_supervisor.analysis.claims import FAILS, HOLDS, NOT_APPLICABLE, ClaimError
from swarm_supervisor.analysis.report import compared_section
from swarm_supervisor.cli import main

POPULATIONS = (10, 30, 50)
SPEEDS = (0.04, 0.08)
END = 100


def synthetic(metrics: Callable[[int, float, int, np.ndarray], dict[str, np.ndarray]], *,
              populations=POPULATIONS, speeds=SPEEDS, seeds=(1, 2, 3), end=END,
              **factors) -> pd.DataFrame:
    """A tidy table whose metrics are ``metrics(n, v, seed, t)`` (unset metrics are 0)."""
    t = np.arange(end + 1, dtype=float)
    frames = []
    for n in populations:
        for v in speeds:
            for seed in seeds:
                frame = pd.DataFrame({'population': n, 'speed': v, 'seed': seed, 't': t,
                                      'mean_cue': 0.0, 'mean_cue_fraction': 0.0,
                                      'ratio_near_source': 0.0, 'coherency': 0.0})
                for name, values in metrics(n, v, seed, t).items():
                    frame[name] = values
                for name, value in factors.items():
                    frame[name] = value
                frames.append(frame)
    return pd.concat(frames, ignore_index=True)


def cleaning(n, v, seed, t, *, swap=False):
    """More and faster robots clean faster (``swap``: N = 30 and 50 trade places)."""
    if swap:
        n = {30: 50, 50: 30}.get(n, n)
    rng = np.random.default_rng([n, int(v * 100), seed])
    fraction = np.exp(-t * n * v / 40) + 0.01 * rng.standard_normal(len(t))
    return {'mean_cue_fraction': fraction, 'mean_cue': 100 * fraction,
            'coherency': 1 + fraction}


def claim(kind: str, **params) -> claims.Claim:
    return claims.parse_claim({'id': f'test-{kind}', 'where': 'test', 'paper': 'words',
                               'check': {'kind': kind, **params}})


def status(table: pd.DataFrame, kind: str, **params) -> claims.ClaimResult:
    return evaluate(table, [claim(kind, **params)])[0]


CLEAN = synthetic(cleaning)
SWAPPED = synthetic(lambda *a: cleaning(*a, swap=True))


def test_order_across_populations_holds_and_fails():
    params = {'metric': 'mean_cue_fraction', 'across': 'population', 'at': [20, 'end'],
              'direction': 'decreasing', 'speeds': [0.08]}
    result = status(CLEAN, 'order', **params)
    assert result.status == HOLDS, result.ours
    assert 'N = 10' in result.ours and 't = 100 s' in result.ours
    assert status(SWAPPED, 'order', **params).status == FAILS
    assert status(CLEAN, 'order', **{**params, 'direction': 'increasing'}).status == FAILS


def test_order_across_speeds_at_every_population():
    params = {'metric': 'mean_cue_fraction', 'across': 'speed', 'at': 30,
              'direction': 'decreasing'}
    assert status(CLEAN, 'order', **params).status == HOLDS
    slow_wins = synthetic(lambda n, v, s, t: cleaning(n, 0.12 - v if n == 30 else v, s, t))
    result = status(slow_wins, 'order', **params)
    assert result.status == FAILS and 'N = 30' in result.ours


def test_extreme_cell_holds_and_fails():
    best = {'metric': 'mean_cue_fraction', 'at': 'end', 'which': 'min',
            'cell': {'population': 50, 'speed': 0.08}}
    worst = dict(best, which='max', cell={'population': 10, 'speed': 0.04})
    assert status(CLEAN, 'extreme', at=20, **{k: v for k, v in best.items() if k != 'at'}
                  ).status == HOLDS
    assert status(CLEAN, 'extreme', **worst).status == HOLDS
    result = status(SWAPPED, 'extreme', at=20, **{k: v for k, v in best.items() if k != 'at'})
    assert result.status == FAILS and 'N = 30 at 8 cm/s' in result.ours


def test_threshold_at_a_time_holds_and_fails():
    params = {'metric': 'mean_cue_fraction', 'populations': [30, 50], 'speeds': [0.08],
              'at': 30, 'op': '<', 'value': 0.5}
    assert status(CLEAN, 'threshold', **params).status == HOLDS
    result = status(CLEAN, 'threshold', **{**params, 'populations': [10, 50]})
    assert result.status == FAILS and 'not < 0.5' in result.ours


def settling(n, v, seed, t, *, kind='settles'):
    rng = np.random.default_rng([n, seed])
    noise = 0.01 * rng.standard_normal(len(t))
    if kind == 'settles':
        ratio = 0.2 + 0.6 * (1 - np.exp(-t / 10))
    elif kind == 'climbs':
        ratio = 0.2 + 0.006 * t
    else:
        ratio = np.full(len(t), 0.2)
    return {'ratio_near_source': ratio + noise, 'coherency': 1.5 - ratio + noise}


@pytest.mark.parametrize('metric, direction', [('ratio_near_source', 'up'),
                                               ('coherency', 'down')])
def test_rises_then_settles_holds_and_fails(metric, direction):
    params = {'metric': metric, 'direction': direction, 'min_change': 0.1, 'smooth': 5}
    assert status(synthetic(settling), 'rises_then_settles', **params).status == HOLDS
    climbing = status(synthetic(lambda *a: settling(*a, kind='climbs')),
                      'rises_then_settles', **params)
    assert climbing.status == FAILS and 'still changing' in climbing.ours
    flat = status(synthetic(lambda *a: settling(*a, kind='flat')), 'rises_then_settles',
                  **params)
    assert flat.status == FAILS and 'does not' in flat.ours
    wrong_way = {'up': 'down', 'down': 'up'}[direction]
    assert status(synthetic(settling), 'rises_then_settles',
                  **{**params, 'direction': wrong_way}).status == FAILS


def test_steady_absolute_and_relative():
    flat = synthetic(lambda *a: settling(*a, kind='flat'))
    rising = synthetic(settling)
    params = {'metric': 'ratio_near_source', 'populations': [10], 'speeds': [0.08],
              'tolerance': 0.2, 'smooth': 5}
    assert status(flat, 'steady', **params).status == HOLDS
    result = status(rising, 'steady', **params)
    assert result.status == FAILS and 'span' in result.ours
    relative = {'metric': 'coherency', 'populations': [10], 'tolerance': 0.2,
                'relative_to': 'start'}
    assert status(flat, 'steady', **relative).status == HOLDS  # 1.3 +- noise
    assert status(rising, 'steady', **relative).status == FAILS  # 1.3 -> 0.7


def planted(effects: dict[str, float]) -> pd.DataFrame:
    """Additive effects of time, population and speed on mean_cue and coherency, plus noise."""
    def metrics(n, v, seed, t):
        rng = np.random.default_rng([n, int(v * 100), seed])
        value = (effects.get('population', 0) * n / 50 + effects.get('speed', 0) * (v == 0.08)
                 + effects.get('time', 0) * t / END + rng.standard_normal(len(t)))
        return {'mean_cue': value, 'coherency': value}
    return synthetic(metrics, seeds=(1, 2, 3, 4))


def test_anova_checks_hold_and_fail():
    strong = planted({'speed': 6.0, 'population': 3.0, 'time': 1.5})
    no_time = planted({'speed': 6.0, 'population': 3.0})
    significant = {'response': 'mean_cue', 'factors': ['time', 'population', 'speed']}
    assert status(strong, 'anova_significant', **significant).status == HOLDS
    result = status(no_time, 'anova_significant', **significant)
    assert result.status == FAILS and 'not significant: time' in result.ours
    order = {'response': 'mean_cue', 'order': ['speed', 'population', 'time']}
    assert status(strong, 'anova_order', **order).status == HOLDS
    assert status(planted({'speed': 1.0, 'population': 6.0, 'time': 1.5}), 'anova_order',
                  **order).status == FAILS
    assert status(strong, 'anova_largest', response='coherency', factor='speed'
                  ).status == HOLDS
    assert status(strong, 'anova_largest', response='coherency', factor='population'
                  ).status == FAILS
    for variant in ('samples', 'medians', 'covariate'):
        assert status(strong, 'anova_largest', response='mean_cue', factor='speed',
                      variant=variant).status == HOLDS, variant


def test_missing_cells_times_and_levels_are_not_applicable():
    result = status(CLEAN, 'threshold', metric='mean_cue', populations=[20], speeds=[0.08],
                    at=10, op='<', value=1)
    assert result.status == NOT_APPLICABLE and 'no N = 20 at 8 cm/s' in result.ours
    result = status(CLEAN, 'order', metric='mean_cue', across='population', at=1500,
                    direction='decreasing')
    assert result.status == NOT_APPLICABLE and 'before t = 1500 s' in result.ours
    one_speed = CLEAN[CLEAN['speed'] == 0.08]
    result = status(one_speed, 'anova_order', response='mean_cue', order=['speed', 'time'])
    assert result.status == NOT_APPLICABLE and 'speed has one level' in result.ours
    result = status(one_speed, 'order', metric='mean_cue', across='speed', at=10,
                    direction='decreasing')
    assert result.status == NOT_APPLICABLE
    result = status(CLEAN, 'extreme', metric='mean_cue', at='end', which='min',
                    cell={'population': 40, 'speed': 0.08})
    assert result.status == NOT_APPLICABLE and 'N = 40' in result.ours


def test_design_factor_levels_are_evaluated_apart():
    fast = synthetic(cleaning, **{'mona.ir_range': 0.03})
    reversed_ = synthetic(lambda *a: cleaning(*a, swap=True), **{'mona.ir_range': 0.1})
    both = pd.concat([fast, reversed_], ignore_index=True)
    order = claim('order', metric='mean_cue_fraction', across='population', at=20,
                  direction='decreasing')
    with pytest.raises(ValueError, match='mona.ir_range'):
        evaluate(both, [order])
    assert evaluate(fast, [order])[0].status == HOLDS  # one level: a subset is fine
    pairs = evaluate_levels(both, [order])
    assert [(levels, [r.status for r in results]) for levels, results in pairs] == [
        ({'mona.ir_range': 0.03}, [HOLDS]), ({'mona.ir_range': 0.1}, [FAILS])]
    text = '\n'.join(compared_section(pairs))
    assert '### mona.ir_range = 0.1' in text and '**does not hold**' in text


def test_shipped_claims_load_cover_every_kind_and_run():
    shipped = claims.paper_claims()
    assert len({c.id for c in shipped}) == len(shipped) >= 10
    assert {c.kind for c in shipped} == set(CHECKS)
    assert {c.where.split()[0] + ' ' + c.where.split()[1].rstrip('ab')
            for c in shipped} >= {'fig. 4', 'fig. 5', 'fig. 6', 'table 2', 'table 3'}
    results = evaluate(CLEAN, shipped)  # 100 s: the claims at 1000 s and more do not apply
    assert [r.id for r in results] == [c.id for c in shipped]
    assert {r.status for r in results} <= set(claims.STATUSES)
    by_id = {r.id: r for r in results}
    assert by_id['fig4-halved-by-1500s'].status == NOT_APPLICABLE
    assert by_id['fig4-best-cell'].status == HOLDS


GOOD = {'id': 'mine', 'where': 'fig. 4', 'paper': 'words',
        'check': {'kind': 'threshold', 'metric': 'mean_cue', 'at': 10, 'op': '<', 'value': 5}}


@pytest.mark.parametrize('change, message', [
    ({'where': None}, "claim 'mine': field 'where' must be non-empty text"),
    ({'paper': ''}, "claim 'mine': field 'paper'"),
    ({'colour': 'red'}, "claim 'mine': unknown field(s) 'colour'"),
    ({'check': {'kind': 'bogus'}}, "claim 'mine': field 'check.kind' must be one of order"),
    ({'check': {**GOOD['check'], 'metric': 'cue'}}, "claim 'mine': field 'check.metric'"),
    ({'check': {**GOOD['check'], 'speeds': [8]}}, "field 'check.speeds' speeds are in m/s"),
    ({'check': {**GOOD['check'], 'op': '=='}}, "field 'check.op' must be one of"),
    ({'check': {**GOOD['check'], 'at': 'later'}}, "field 'check.at' must be a finite"),
    ({'check': {**GOOD['check'], 'populations': [0]}}, "field 'check.populations'"),
    ({'check': {**GOOD['check'], 'extra': 1}}, "unknown field(s) 'check.extra' for kind"),
    ({'check': {k: v for k, v in GOOD['check'].items() if k != 'value'}},
     "claim 'mine': field 'check.value' is missing (kind threshold)"),
])
def test_a_bad_claim_names_its_id_and_field(change, message):
    entry = {**GOOD, **change}
    with pytest.raises(ClaimError) as raised:
        claims.parse_claims({'claims': [GOOD | {'id': 'other'}, entry]})
    assert message in str(raised.value)


def test_claims_files_load_add_and_refuse_duplicates(tmp_path):
    path = tmp_path / 'mine.yaml'
    path.write_text(yaml.safe_dump({'claims': [GOOD]}))
    added = claims.all_claims([path])
    assert added[-1].id == 'mine' and len(added) == len(claims.paper_claims()) + 1
    duplicate = tmp_path / 'dup.yaml'
    duplicate.write_text(yaml.safe_dump({'claims': [GOOD | {'id': 'fig4-best-cell'}]}))
    with pytest.raises(ClaimError, match="claim 'fig4-best-cell': field 'id' is used twice"):
        claims.all_claims([duplicate])
    no_id = tmp_path / 'noid.yaml'
    no_id.write_text(yaml.safe_dump({'claims': [{k: v for k, v in GOOD.items() if k != 'id'}]}))
    with pytest.raises(ClaimError, match="claim #1: field 'id' is missing"):
        claims.load_claims(no_id)
    with pytest.raises(ClaimError, match='one key, claims'):
        claims.parse_claims([GOOD])


def test_study_command_refuses_a_bad_claims_file_before_running(tmp_path, capsys):
    bad = tmp_path / 'bad.yaml'
    bad.write_text(yaml.safe_dump({'claims': [GOOD | {'where': ''}]}))
    status_code = main(['study', '--out', str(tmp_path / 'out'), '--claims', str(bad),
                        '--quick'])
    assert status_code == 2
    assert "claim 'mine': field 'where'" in capsys.readouterr().err
    assert not (tmp_path / 'out').exists()


def test_values_are_medians_over_seeds():
    # Seed 3 is an outlier; the median ignores it, a mean would not.
    table = synthetic(lambda n, v, s, t: {'mean_cue': np.full(len(t), 100.0 if s == 3
                                                              else float(n))})
    result = status(table, 'threshold', metric='mean_cue', populations=[10], speeds=[0.04],
                    at=5, op='<=', value=10)
    assert result.status == HOLDS and math.isclose(
        result.values['5|N = 10 at 4 cm/s'], 10.0)


def test_extreme_compares_the_named_cells_the_table_has():
    params = {'metric': 'mean_cue_fraction', 'at': 'end', 'which': 'max',
              'cell': {'population': 30, 'speed': 0.04}}
    assert status(CLEAN, 'extreme', **params).status == FAILS  # N = 10 is worse
    named = status(CLEAN, 'extreme', populations=[20, 30, 40, 50], **params)
    assert named.status == HOLDS, named.ours  # N = 20 and 40 are absent: skipped


def test_rises_then_settles_accepts_a_peak_that_falls_back():
    # The paper's swarm gathers at the source, then disperses as the cue vanishes.
    def peak(n, v, seed, t):
        return {'ratio_near_source': 0.2 + 0.7 * np.exp(-((t - 20) / 10) ** 2)}
    result = status(synthetic(peak), 'rises_then_settles', metric='ratio_near_source',
                    min_change=0.5)
    assert result.status == HOLDS and 'peak 0.9 at 20 s' in result.ours
    assert status(synthetic(peak), 'rises_then_settles', metric='ratio_near_source',
                  min_change=0.8).status == FAILS
