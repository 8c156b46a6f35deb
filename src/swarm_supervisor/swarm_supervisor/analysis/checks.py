"""The check kinds a claim names, and the claims evaluated on a study's tidy table.

Every value a check compares is the median over seeds of the metric at a sample time (the
curves of figs. 4-6), optionally smoothed by a trailing moving average over ``smooth``
seconds. A check returns (holds, ours, values) or raises :class:`NotApplicable` when the table
lacks what the claim needs. :func:`evaluate` computes everything else a claim needs (e.g. the
ANOVA) itself, so that it can be called on any subset of a sweep (one per factor level).
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from swarm_supervisor import study
from swarm_supervisor.analysis import anova as anova_tables
from swarm_supervisor.analysis.claims import (
    FAILS,
    HOLDS,
    NOT_APPLICABLE,
    SPEED_TOLERANCE,
    Claim,
    ClaimResult,
)


class NotApplicable(Exception):
    """Raised inside a check: the table lacks what the claim needs (the message says what)."""


def _label(population: int, speed: float) -> str:
    return f'N = {population} at {speed * 100:g} cm/s'


def _cells(table: pd.DataFrame, params: Mapping[str, Any],
           require: bool = True) -> list[tuple[int, float]]:
    """The (population, speed) cells a claim names (all the table's when it names none);
    raises NotApplicable for a named cell the table lacks (``require``; else skips it)."""
    present = {(int(n), float(v)) for n, v in
               table[['population', 'speed']].drop_duplicates().itertuples(index=False)}
    populations = params['populations'] or sorted({n for n, _ in present})
    speeds = params['speeds'] or sorted({v for _, v in present})
    cells, missing = [], []
    for n in populations:
        for v in speeds:
            match = [cell for cell in present if cell[0] == n
                     and abs(cell[1] - v) < SPEED_TOLERANCE]
            if match:
                cells.append(match[0])
            else:
                missing.append(_label(n, v))
    if missing and require:
        raise NotApplicable(f'the table has no {", ".join(missing)}')
    return cells


def _curve(table: pd.DataFrame, metric: str, cell: tuple[int, float],
           smooth: float) -> pd.Series:
    """The median over seeds of ``metric`` in one cell, indexed by t, optionally smoothed by a
    trailing moving average over ``smooth`` seconds."""
    rows = table[(table['population'] == cell[0])
                 & (np.abs(table['speed'] - cell[1]) < SPEED_TOLERANCE)]
    curve = rows.groupby('t')[metric].median().sort_index()
    if smooth > 0 and len(curve) > 1:
        period = float(np.median(np.diff(curve.index.to_numpy())))
        window = max(1, int(round(smooth / period)))
        curve = curve.rolling(window, min_periods=1).mean()
    return curve


def _end(table: pd.DataFrame) -> float:
    """The last time every episode reached (the shortest episode's end)."""
    keys = list(study.KEYS) + study.design_factors(table)
    return float(table.groupby(keys)['t'].max().min())


def _value_at(curve: pd.Series, at: float | str, end: float) -> tuple[float, float]:
    """The curve at time ``at`` ('end': the shortest episode's end): the value at the last
    sample at or before it, and that sample's time."""
    t = end if at == 'end' else float(at)
    if t > end + 1e-9:
        raise NotApplicable(f'the episodes end at {end:g} s, before t = {t:g} s')
    before = curve.index[curve.index <= t + 1e-9]
    if not len(before):
        raise NotApplicable(f'no sample at or before t = {t:g} s')
    return float(curve.loc[before[-1]]), float(before[-1])


def _values(table: pd.DataFrame, params: Mapping[str, Any], at: float | str,
            cells: Sequence[tuple[int, float]]) -> tuple[dict[tuple[int, float], float], float]:
    end = _end(table)
    values, when = {}, 0.0
    for cell in cells:
        values[cell], when = _value_at(_curve(table, params['metric'], cell, params['smooth']),
                                       at, end)
    return values, when


def _number_text(value: float) -> str:
    return f'{value:.3g}'


# The checks: each returns (holds, ours, values) or raises NotApplicable.

CheckResult = tuple[bool, str, dict[str, Any]]


def check_order(table: pd.DataFrame, p: Mapping[str, Any]) -> CheckResult:
    """The metric (median over seeds) at each time in ``at`` is strictly increasing or
    decreasing ``across`` populations (at each speed) or speeds (at each population)."""
    cells = _cells(table, p)
    other = 'speed' if p['across'] == 'population' else 'population'
    index = 0 if p['across'] == 'population' else 1
    groups: dict[float, list[tuple[int, float]]] = {}
    for cell in cells:
        groups.setdefault(cell[1 - index], []).append(cell)
    if not any(len(group) > 1 for group in groups.values()):
        raise NotApplicable(f'one {p["across"]} only: nothing to order')
    holds, parts, values = True, [], {}
    for at in p['at']:
        found, when = _values(table, p, at, cells)
        for key, group in sorted(groups.items()):
            group = sorted(group, key=lambda cell: cell[index])
            series = [found[cell] for cell in group]
            steps = np.diff(series)
            ok = bool(np.all(steps > 0) if p['direction'] == 'increasing' else np.all(steps < 0))
            holds &= ok
            fixed = f'{key * 100:g} cm/s' if other == 'speed' else f'N = {key}'
            listing = ', '.join(
                (f'N = {cell[0]}' if index == 0 else f'{cell[1] * 100:g} cm/s') + ': '
                + _number_text(found[cell]) for cell in group)
            parts.append(f't = {when:g} s, {fixed}: {listing}' + ('' if ok else ' (not '
                                                                   f'{p["direction"]})'))
            values[f'{when:g}|{fixed}'] = series
    return holds, '; '.join(parts), values


def check_extreme(table: pd.DataFrame, p: Mapping[str, Any]) -> CheckResult:
    """At each time in ``at``, ``cell`` has the lowest (``which: min``) or highest value of
    the metric among the cells named that the table has (default: all the table's)."""
    target = p['cell']
    cells = _cells(table, p, require=False)
    wanted = _cells(table, {'populations': [target['population']],
                            'speeds': [target['speed']]})[0]
    if wanted not in cells:
        cells.append(wanted)
    if len(cells) < 2:
        raise NotApplicable('one cell only: no best or worst')
    holds, parts, values = True, [], {}
    for at in p['at']:
        found, when = _values(table, p, at, cells)
        pick = min if p['which'] == 'min' else max
        extreme = pick(found, key=found.__getitem__)
        ok = found[extreme] == found[wanted]  # a tie with the named cell counts as its extreme
        holds &= ok
        parts.append(f't = {when:g} s: {p["which"]} is {_label(*extreme)} '
                     f'({_number_text(found[extreme])})' + ('' if ok else
                                                          f'; {_label(*wanted)}: '
                                                          f'{_number_text(found[wanted])}'))
        values[f'{when:g}'] = {'extreme': list(extreme), 'value': found[extreme],
                               'cell_value': found[wanted]}
    return holds, '; '.join(parts), values


_OPS = {'<': operator.lt, '<=': operator.le, '>': operator.gt, '>=': operator.ge}


def check_threshold(table: pd.DataFrame, p: Mapping[str, Any]) -> CheckResult:
    """At each time in ``at``, the metric of every cell named satisfies ``op value``."""
    cells = _cells(table, p)
    holds, parts, values = True, [], {}
    for at in p['at']:
        found, when = _values(table, p, at, cells)
        for cell in cells:
            ok = bool(_OPS[p['op']](found[cell], p['value']))
            holds &= ok
            parts.append(f'{_label(*cell)} at t = {when:g} s: {_number_text(found[cell])}'
                         + ('' if ok else f' (not {p["op"]} {p["value"]:g})'))
            values[f'{when:g}|{_label(*cell)}'] = found[cell]
    return holds, '; '.join(parts), values


def check_rises_then_settles(table: pd.DataFrame, p: Mapping[str, Any]) -> CheckResult:
    """For each cell named, the curve rises (``direction: up``; falls for ``down``): its peak
    (trough) lies more than ``min_change`` above (below) its first sample; and it has settled
    by the end: the mean of its last ``share`` of the episode differs from the mean of the
    ``share`` before by at most ``tolerance`` times the curve's range (max - min). Where it
    settles is free: the paper's swarm gathers, then disperses as the cue vanishes."""
    cells = _cells(table, p)
    holds, parts, values = True, [], {}
    for cell in cells:
        curve = _curve(table, p['metric'], cell, p['smooth'])
        t, y = curve.index.to_numpy(), curve.to_numpy()
        end = t.max()
        last = y[t > end * (1 - p['share'])]
        before = y[(t > end * (1 - 2 * p['share'])) & (t <= end * (1 - p['share']))]
        if not len(last) or not len(before):
            raise NotApplicable(f'{_label(*cell)} has too few samples to compare the last '
                                f'{p["share"]:.0%} of the episode with the one before')
        start, final = float(y[0]), float(np.mean(last))
        extreme = int(np.argmax(y) if p['direction'] == 'up' else np.argmin(y))
        change = y[extreme] - start if p['direction'] == 'up' else start - y[extreme]
        drift = float(np.mean(last) - np.mean(before))
        span = float(np.max(y) - np.min(y))
        settled = abs(drift) <= p['tolerance'] * span if span > 0 else True
        moved = change > p['min_change']
        holds &= moved and settled
        verb = 'rises' if p['direction'] == 'up' else 'falls'
        parts.append(f'{_label(*cell)}: {_number_text(start)} -> '
                     f'{"peak" if p["direction"] == "up" else "trough"} '
                     f'{_number_text(y[extreme])} at {t[extreme]:g} s '
                     f'({verb if moved else "does not " + verb[:-1]}) -> '
                     f'{_number_text(final)} over the last {p["share"]:.0%}, '
                     f'{"settled" if settled else "still changing"} ({drift:+.3g} from the '
                     f'{p["share"]:.0%} before; range {_number_text(span)})')
        values[_label(*cell)] = {'start': start, 'extreme': float(y[extreme]), 'end': final,
                                 'drift': drift, 'span': span}
    return holds, '; '.join(parts), values


def check_steady(table: pd.DataFrame, p: Mapping[str, Any]) -> CheckResult:
    """'Does not change considerably': for each cell named, the range (max - min) of the
    curve is at most ``tolerance`` (in the metric's units, or with ``relative_to: start`` as
    a fraction of the curve's first value)."""
    cells = _cells(table, p)
    holds, parts, values = True, [], {}
    for cell in cells:
        curve = _curve(table, p['metric'], cell, p['smooth'])
        span = float(curve.max() - curve.min())
        start = float(curve.iloc[0])
        limit = p['tolerance'] * abs(start) if p['relative_to'] == 'start' else p['tolerance']
        ok = span <= limit
        holds &= ok
        parts.append(f'{_label(*cell)}: from {_number_text(start)}, range '
                     f'{_number_text(curve.min())}-{_number_text(curve.max())} '
                     f'(span {_number_text(span)} {"<=" if ok else ">"} {_number_text(limit)})')
        values[_label(*cell)] = {'start': start, 'min': float(curve.min()),
                                 'max': float(curve.max()), 'span': span, 'limit': limit}
    return holds, '; '.join(parts), values


def _anova(table: pd.DataFrame, p: Mapping[str, Any],
           factors: Sequence[str]) -> pd.DataFrame:
    """The ANOVA a claim reads, with every factor it names tested (else NotApplicable)."""
    try:
        result = anova_tables.anova(table, p['response'], variant=p['variant'])
    except ValueError as error:
        raise NotApplicable(str(error)) from None
    result = result[result['factor'] != 'residual'].set_index('factor')
    for factor in factors:
        if factor not in result.index:
            raise NotApplicable(f'the table has no factor {factor}')
        if not np.isfinite(result.loc[factor, 'F']):
            raise NotApplicable(f'{factor} has one level in the table: it cannot be tested')
    return result


def _f_text(result: pd.DataFrame) -> str:
    # p underflows to 0 for large F: say so rather than print 'p = 0'.
    return ', '.join(f'{name} F = {row.F:.4g} (p ' + ('< 1e-300)' if row.p == 0 else
                                                     f'= {row.p:.2g})')
                     for name, row in result.sort_values('F', ascending=False).iterrows()
                     if np.isfinite(row.F))


def check_anova_significant(table: pd.DataFrame, p: Mapping[str, Any]) -> CheckResult:
    """Every factor named (default: every factor the table varies) has p < ``alpha`` in the
    ANOVA of ``response`` (:func:`swarm_supervisor.analysis.anova.anova`, ``variant``)."""
    result = _anova(table, p, p['factors'])
    factors = list(p['factors']) or [f for f in result.index if np.isfinite(result.loc[f, 'F'])]
    failing = [f for f in factors if not result.loc[f, 'p'] < p['alpha']]
    return (not failing, _f_text(result) + (f'; not significant: {", ".join(failing)}'
                                            if failing else ''),
            {f: float(result.loc[f, 'F']) for f in factors})


def check_anova_order(table: pd.DataFrame, p: Mapping[str, Any]) -> CheckResult:
    """The factors named, ranked by F (largest first), come in the ``order`` given."""
    result = _anova(table, p, p['order'])
    ranked = sorted(p['order'], key=lambda f: -result.loc[f, 'F'])
    return (ranked == list(p['order']), _f_text(result) + f'; order {" > ".join(ranked)}',
            {f: float(result.loc[f, 'F']) for f in p['order']})


def check_anova_largest(table: pd.DataFrame, p: Mapping[str, Any]) -> CheckResult:
    """``factor`` has the largest F of all the factors the table varies."""
    result = _anova(table, p, [p['factor']])
    tested = result[np.isfinite(result['F'])]
    largest = str(tested['F'].idxmax())
    return (largest == p['factor'], _f_text(result) + f'; largest: {largest}',
            {f: float(tested.loc[f, 'F']) for f in tested.index})


#: The check kinds, by the name a claim's ``check.kind`` uses.
CHECKS: dict[str, Callable[[pd.DataFrame, Mapping[str, Any]], CheckResult]] = {
    'order': check_order, 'extreme': check_extreme, 'threshold': check_threshold,
    'rises_then_settles': check_rises_then_settles, 'steady': check_steady,
    'anova_significant': check_anova_significant, 'anova_order': check_anova_order,
    'anova_largest': check_anova_largest,
}


def evaluate(table: pd.DataFrame, claims: Sequence[Claim]) -> list[ClaimResult]:
    """Check every claim on one study's tidy table.

    Args:
        table: the tidy table (``all_metrics.csv``; speed in m/s). It may hold design factor
            columns (:func:`swarm_supervisor.study.table.design_factors`), each with one level: to
            check a sweep, call this once per subset (one factor level each), or use
            :func:`evaluate_levels`.
        claims: e.g. :func:`paper_claims` or :func:`all_claims`.

    Returns:
        One result per claim, in order: ``holds``, ``does not hold``, or ``not applicable``
        (the table lacks a cell, a time or a factor level the claim needs; ``ours`` says which).

    Raises:
        ValueError: a design factor has more than one level in the table (medians over seeds
            would pool its levels).
    """
    mixed = [f for f in study.design_factors(table) if table[f].nunique() > 1]
    if mixed:
        raise ValueError(f'the table mixes the levels of {", ".join(mixed)}: evaluate each '
                         'level on its own (checks.evaluate_levels)')
    results = []
    for claim in claims:
        lacking = [name for name in (claim.params.get('metric'), claim.params.get('response'))
                   if name is not None and name not in table.columns]
        if lacking:  # e.g. episodes run without the plug-in of a claim's metric
            results.append(ClaimResult(claim, NOT_APPLICABLE,
                                       f'the table has no column {lacking[0]}'))
            continue
        try:
            holds, ours, values = CHECKS[claim.kind](table, claim.params)
        except NotApplicable as reason:
            results.append(ClaimResult(claim, NOT_APPLICABLE, str(reason)))
            continue
        results.append(ClaimResult(claim, HOLDS if holds else FAILS, ours, values))
    return results


def evaluate_levels(table: pd.DataFrame, claims: Sequence[Claim]
                    ) -> list[tuple[dict[str, Any], list[ClaimResult]]]:
    """:func:`evaluate` on each combination of the design factors' levels.

    Returns:
        (levels, results) pairs, ``levels`` mapping each design factor to its value (an empty
        mapping and the whole table when the design has no extra factor).
    """
    factors = study.design_factors(table)
    if not factors:
        return [({}, evaluate(table, claims))]
    pairs = []
    for key, subset in table.groupby(factors, sort=True):
        key = key if isinstance(key, tuple) else (key,)
        pairs.append((dict(zip(factors, key)), evaluate(subset, claims)))
    return pairs
