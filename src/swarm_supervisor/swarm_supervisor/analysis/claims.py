"""The paper's claims as data, checked against a study's tidy table.

A claim is one finding of the paper's results section: an ``id``, ``where`` it is made (fig. 4,
table 2, ...), the ``paper``'s words or numbers, and a ``check``: one of a small library of
generic, parameterised check kinds (:data:`PARAMETERS`, checked by
:mod:`swarm_supervisor.analysis.checks`), so a claim of one's own needs a few lines
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
from collections.abc import Callable, Iterable, Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from mona_controller.schema import ParameterError
from swarm_metrics.metrics import metric_columns
from swarm_supervisor.analysis import anova as anova_tables
from swarm_supervisor.yaml_text import parse_yaml, read_yaml

HOLDS = 'holds'
FAILS = 'does not hold'
NOT_APPLICABLE = 'not applicable'
STATUSES = (HOLDS, FAILS, NOT_APPLICABLE)
#: The shipped claims, package data of swarm_supervisor.analysis.
PAPER_CLAIMS = 'paper_claims.yaml'
CLAIM_FIELDS = ('id', 'where', 'paper', 'check')
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


# Parameter validation: each check kind declares its parameters with a converter that raises
# ValueError on a bad value, so every claim is checked when it is loaded, not when evaluated.

def _metric(value: Any) -> str:
    """A metrics.csv column: t or a metric of the table (swarm_metrics.metrics.METRICS)."""
    allowed = metric_columns()
    if value not in allowed:
        raise ValueError(f'must be one of {", ".join(allowed)}, not {value!r} (a metric of '
                         'your own is a plug-in: docs/extending.md#a-metric)')
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
_ANOVA = {'response': (_metric, None),
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
                         f'{", ".join(PARAMETERS)})')
    kind = check['kind']
    if kind not in PARAMETERS:
        raise ClaimError(f'{label}: field \'check.kind\' must be one of {", ".join(PARAMETERS)}, '
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
    return parse_claims(read_yaml(path, ClaimError), str(path))


def paper_claims() -> list[Claim]:
    """The paper's claims shipped with swarm_supervisor (``paper_claims.yaml``)."""
    source = resources.files('swarm_supervisor.analysis') / PAPER_CLAIMS
    return parse_claims(parse_yaml(source.read_text(), PAPER_CLAIMS, ClaimError), PAPER_CLAIMS)


def all_claims(extra: Iterable[str | Path] = ()) -> list[Claim]:
    """The paper's claims followed by those of each file in ``extra`` (ids must be unique)."""
    claims = paper_claims()
    for path in extra:
        claims += load_claims(path)
    check_unique(claims, "the paper's and the added claims")
    return claims


# The curves the checks read.
