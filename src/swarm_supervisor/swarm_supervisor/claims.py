"""The paper's claims as data, checked against a study's tidy table.

A claim is one finding of the paper's results section: an ``id``, ``where`` it is made (fig. 4,
table 2, ...), the ``paper``'s words or numbers, and a ``check``: one of a small library of
generic, parameterised check kinds (:data:`CHECKS`), so a claim of one's own needs a few lines
of YAML and no code. The paper's claims ship as ``paper_claims.yaml`` beside this module
(:func:`paper_claims`); ``mona-swarm study --claims FILE`` adds a user's.

:func:`evaluate` takes the tidy table (``all_metrics.csv``: population, speed, seed, t and the
metrics; speed in m/s) and computes everything else it needs itself, e.g. the ANOVA, so that it
can be called on any subset of a sweep (one per factor level). A claim whose cells are missing
from the table is ``not applicable`` (with the reason), never an error.

Every value a check compares is the median over seeds of the metric at a sample time (the
curves of figs. 4-6), optionally smoothed by a trailing moving average over ``smooth`` seconds
(fig. 5 smooths over 20 s).
"""

from __future__ import annotations

import dataclasses
import math
import operator
from collections.abc import Callable, Iterable, Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from mona_controller.schema import ParameterError
from swarm_metrics.metrics import COLUMNS
from swarm_supervisor import anova as anova_tables
from swarm_supervisor import study

HOLDS = 'holds'
FAILS = 'does not hold'
NOT_APPLICABLE = 'not applicable'
STATUSES = (HOLDS, FAILS, NOT_APPLICABLE)
PAPER_CLAIMS = 'paper_claims.yaml'  #: the shipped claims, package data of swarm_supervisor
CLAIM_FIELDS = ('id', 'where', 'paper', 'check')
METRICS = tuple(COLUMNS)
SPEED_TOLERANCE = 1e-9  #: m/s: speeds in the table and in a claim match within this


class ClaimError(ParameterError):
    """A claims file or claim is malformed; the message names the claim id and the field (a
    ParameterError, so the command line reports it in one line with exit status 2)."""


@dataclasses.dataclass(frozen=True)
class Claim:
    """One finding of the paper (or a user's), with the check that tests it on our data."""

    id: str
    where: str
    paper: str
    kind: str
    params: Mapping[str, Any]


@dataclasses.dataclass(frozen=True)
class ClaimResult:
    """The outcome of one claim on one table.

    Attributes:
        status: one of :data:`STATUSES`.
        ours: our numbers, in words (or why the claim is not applicable).
        values: the numbers behind ``ours``, for tables built from many results.
    """

    claim: Claim
    status: str
    ours: str
    values: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    @property
    def id(self) -> str:
        """The claim's id (results are keyed by it)."""
        return self.claim.id


class NotApplicable(Exception):
    """Raised inside a check: the table lacks what the claim needs (the message says what)."""


# Parameter validation: each check kind declares its parameters with a converter that raises
# ValueError on a bad value, so every claim is checked when it is loaded, not when evaluated.

def _metric(value: Any) -> str:
    if value not in METRICS:
        raise ValueError(f'must be one of {", ".join(METRICS)}, not {value!r}')
    return value


def _number(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f'must be a finite number, not {value!r}')
    return float(value)


def _non_negative(value: Any) -> float:
    number = _number(value)
    if number < 0:
        raise ValueError(f'must be >= 0, not {value!r}')
    return number


def _time(value: Any) -> float | str:
    if value == 'end':
        return value
    number = _non_negative(value)
    return number


def _times(value: Any) -> tuple[float | str, ...]:
    values = value if isinstance(value, list) else [value]
    if not values:
        raise ValueError('must name at least one time')
    return tuple(_time(v) for v in values)


def _populations(value: Any) -> tuple[int, ...]:
    if not isinstance(value, list) or not value or not all(
            isinstance(v, int) and not isinstance(v, bool) and v > 0 for v in value):
        raise ValueError(f'must be a non-empty list of positive integers, not {value!r}')
    return tuple(value)


def _speeds(value: Any) -> tuple[float, ...]:
    if not isinstance(value, list) or not value:
        raise ValueError(f'must be a non-empty list of speeds in m/s, not {value!r}')
    speeds = tuple(_non_negative(v) for v in value)
    if max(speeds) > 1.0:  # a speed in cm/s by mistake would silently match no cell
        raise ValueError(f'speeds are in m/s (0.08 for 8 cm/s), not {value!r}')
    return speeds


def _choice(*options: str) -> Callable[[Any], str]:
    def convert(value: Any) -> str:
        if value not in options:
            raise ValueError(f'must be one of {", ".join(options)}, not {value!r}')
        return value
    return convert


def _factor(value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f'must be a factor name (time, population, speed or a design '
                         f'factor), not {value!r}')
    return value


def _factors(value: Any) -> tuple[str, ...]:
    if not isinstance(value, list) or not value:
        raise ValueError(f'must be a non-empty list of factor names, not {value!r}')
    return tuple(_factor(v) for v in value)


def _cell(value: Any) -> dict[str, float]:
    if not isinstance(value, dict) or set(value) != {'population', 'speed'}:
        raise ValueError(f'must be {{population: N, speed: m/s}}, not {value!r}')
    return {'population': _populations([value['population']])[0],
            'speed': _speeds([value['speed']])[0]}


def _fraction(value: Any) -> float:
    number = _number(value)
    if not 0 < number < 1:
        raise ValueError(f'must lie in (0, 1), not {value!r}')
    return number


#: Parameters each check shares: which curve, where, smoothed how.
_CURVE = {'metric': (_metric, None), 'populations': (_populations, ()),
          'speeds': (_speeds, ()), 'smooth': (_non_negative, 0.0)}
_ANOVA = {'response': (_choice('mean_cue', 'coherency', *METRICS), None),
          'variant': (_choice(*anova_tables.VARIANTS), anova_tables.DEFAULT_VARIANT)}

#: Each check kind's parameters: name -> (converter, default; None = required).
PARAMETERS: dict[str, dict[str, tuple[Callable[[Any], Any], Any]]] = {
    'order': {**_CURVE, 'across': (_choice('population', 'speed'), None),
              'at': (_times, None), 'direction': (_choice('increasing', 'decreasing'), None)},
    'extreme': {**_CURVE, 'at': (_times, None), 'which': (_choice('min', 'max'), None),
                'cell': (_cell, None)},
    'threshold': {**_CURVE, 'at': (_times, None),
                  'op': (_choice('<', '<=', '>', '>='), None), 'value': (_number, None)},
    'rises_then_settles': {**_CURVE, 'direction': (_choice('up', 'down'), 'up'),
                           'min_change': (_non_negative, 0.0),
                           'share': (_fraction, 0.1), 'tolerance': (_fraction, 0.05)},
    'steady': {**_CURVE, 'tolerance': (_non_negative, None),
               'relative_to': (_choice('absolute', 'start'), 'absolute')},
    'anova_significant': {**_ANOVA, 'factors': (_factors, ()), 'alpha': (_fraction, 0.05)},
    'anova_order': {**_ANOVA, 'order': (_factors, None)},
    'anova_largest': {**_ANOVA, 'factor': (_factor, None)},
}


def parse_claim(entry: Any, index: int = 0) -> Claim:
    """One claim from its YAML mapping, every field validated.

    Raises:
        ClaimError: naming the claim (its id, else its position) and the bad field.
    """
    label = f'claim #{index + 1}'
    if not isinstance(entry, dict):
        raise ClaimError(f'{label}: must be a mapping with fields {", ".join(CLAIM_FIELDS)}')
    if isinstance(entry.get('id'), str) and entry['id'].strip():
        label = f'claim {entry["id"]!r}'
    for name in CLAIM_FIELDS:
        if name not in entry:
            raise ClaimError(f'{label}: field {name!r} is missing')
    unknown = sorted(set(entry) - set(CLAIM_FIELDS))
    if unknown:
        raise ClaimError(f'{label}: unknown field(s) {", ".join(map(repr, unknown))} (a claim '
                         f'has {", ".join(CLAIM_FIELDS)})')
    for name in ('id', 'where', 'paper'):
        if not isinstance(entry[name], str) or not entry[name].strip():
            raise ClaimError(f'{label}: field {name!r} must be non-empty text')
    check = entry['check']
    if not isinstance(check, dict) or 'kind' not in check:
        raise ClaimError(f"{label}: field 'check' must be a mapping with a kind (one of "
                         f'{", ".join(CHECKS)})')
    kind = check['kind']
    if kind not in PARAMETERS:
        raise ClaimError(f'{label}: field \'check.kind\' must be one of {", ".join(CHECKS)}, '
                         f'not {kind!r}')
    schema = PARAMETERS[kind]
    unknown = sorted(set(check) - set(schema) - {'kind'})
    if unknown:
        raise ClaimError(f'{label}: unknown field(s) '
                         + ', '.join(f"'check.{name}'" for name in unknown)
                         + f' for kind {kind} (it takes {", ".join(schema)})')
    params = {}
    for name, (convert, default) in schema.items():
        if name not in check:
            if default is None:
                raise ClaimError(f"{label}: field 'check.{name}' is missing (kind {kind})")
            params[name] = default
            continue
        try:
            params[name] = convert(check[name])
        except ValueError as error:
            raise ClaimError(f"{label}: field 'check.{name}' {error}") from None
    return Claim(id=entry['id'], where=entry['where'], paper=' '.join(entry['paper'].split()),
                 kind=kind, params=params)


def parse_claims(document: Any, source: str = 'the claims') -> list[Claim]:
    """Claims from a parsed YAML document ``{claims: [...]}``.

    Raises:
        ClaimError: the document's shape is wrong, a claim is invalid, or two share an id.
    """
    if not isinstance(document, dict) or set(document) != {'claims'} or not isinstance(
            document['claims'], list):
        raise ClaimError(f'{source}: must be a mapping with one key, claims: a list of claims')
    claims = [parse_claim(entry, index) for index, entry in enumerate(document['claims'])]
    check_unique(claims, source)
    return claims


def check_unique(claims: Sequence[Claim], source: str = 'the claims') -> None:
    """Raise :class:`ClaimError` when two claims share an id (results are keyed by id)."""
    seen: set[str] = set()
    for claim in claims:
        if claim.id in seen:
            raise ClaimError(f"{source}: claim {claim.id!r}: field 'id' is used twice")
        seen.add(claim.id)


def load_claims(path: str | Path) -> list[Claim]:
    """Read and validate a claims file (YAML, see ``paper_claims.yaml`` for the format)."""
    try:
        document = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as error:
        raise ClaimError(f'{path}: cannot read the claims: {error}') from None
    return parse_claims(document, str(path))


def paper_claims() -> list[Claim]:
    """The paper's claims shipped with swarm_supervisor (``paper_claims.yaml``)."""
    source = resources.files('swarm_supervisor') / PAPER_CLAIMS
    return parse_claims(yaml.safe_load(source.read_text()), PAPER_CLAIMS)


def all_claims(extra: Iterable[str | Path] = ()) -> list[Claim]:
    """The paper's claims followed by those of each file in ``extra`` (ids must be unique)."""
    claims = paper_claims()
    for path in extra:
        claims += load_claims(path)
    check_unique(claims, "the paper's and the added claims")
    return claims


# The curves the checks read.

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
        extreme = pick(found, key=found.get)
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
    ANOVA of ``response`` (:func:`swarm_supervisor.anova.anova`, ``variant``)."""
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
            columns (:func:`swarm_supervisor.study.design_factors`), each with one level: to
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
                         'level on its own (claims.evaluate_levels)')
    results = []
    for claim in claims:
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
