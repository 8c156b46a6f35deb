"""The checks of an episode's record, one by one: each returns a :class:`Finding` per failure
(empty list: passed). :func:`swarm_metrics.bags.completeness.check_bag` runs them all on a bag,
the one verdict every consumer of a bag uses (the checks are listed there); each takes plain
tables or numbers, so a table without a bag (an episode folder's metrics.csv) is checked by
the same code.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from mona_controller.topics import CLEANING, ROBOT_STATES, SOURCES, STATUS
from swarm_metrics.metrics import metric_names

#: Every check, in the order they are reported.
CHECKS = ('readable', 'announcement', 'finished', 'cleaning', 'samples', 'cue_maps',
          'online_metrics', 'robot_states', 'sources')
#: world.cleaning modes whose cue the cleaning record rebuilds exactly (swarm_world.cue.clean).
DETERMINISTIC_CLEANING = frozenset({'monotone', 'literal'})
#: Where the sample checks look.
RECOMPUTED, ONLINE = 'recomputed rows', '/metrics/*'
_SHOWN_SPANS = 4  # gaps listed in a samples finding before '...'


@dataclasses.dataclass(frozen=True)
class Finding:
    """One failed check: which, where it failed, and what is wrong or missing."""

    check: str  #: one of :data:`CHECKS`
    where: str  #: the topic, table or file that failed it
    detail: str  #: what is missing or differs (first missing second, largest difference, ...)

    def __str__(self) -> str:
        return f'{self.check} ({self.where}): {self.detail}'

    def to_dict(self) -> dict[str, str]:
        """The finding as episode.json stores it."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, mapping: Any) -> Finding:
        """Read a finding back from episode.json.

        Raises:
            ValueError: ``mapping`` is not a finding.
        """
        if not isinstance(mapping, dict) or not all(
                isinstance(mapping.get(key), str) for key in ('check', 'where', 'detail')):
            raise ValueError(f'not a completeness finding: {mapping!r}')
        return cls(mapping['check'], mapping['where'], mapping['detail'])


def failed_checks(findings: Iterable[Finding]) -> list[str]:
    """The names of the checks that failed, in :data:`CHECKS` order."""
    failed = {finding.check for finding in findings}
    return [check for check in CHECKS if check in failed]


def describe(findings: Sequence[Finding], indent: str = '  ') -> str:
    """The findings, one per line, for an error message or a report."""
    return '\n'.join(f'{indent}{finding}' for finding in findings)


# --- samples ------------------------------------------------------------------------------

def last_index(duration: float, sample_period: float) -> int:
    """The index k of the last sample boundary k * sample_period within the episode."""
    return round(duration * 1e9) // round(sample_period * 1e9)


def check_indices(present: Iterable[int], last: int, sample_period: float,
                  where: str) -> list[Finding]:
    """The ``samples`` check on sample indices (k of t = k * sample_period).

    Args:
        present: the indices recorded (others, e.g. beyond ``last``, are ignored).
        last: the index of the last boundary of the episode (:func:`last_index`).
        sample_period: s, to report times.
        where: what was checked, for the finding.

    Returns:
        One finding naming the first missing second, how many samples are missing and the
        gaps, or none when every boundary 0..last is present.
    """
    present = set(present)
    missing = [k for k in range(last + 1) if k not in present]
    if not missing:
        return []
    spans: list[list[int]] = []
    for k in missing:
        if spans and k == spans[-1][1] + 1:
            spans[-1][1] = k
        else:
            spans.append([k, k])
    shown = ', '.join(f'{a * sample_period:g}' if a == b else
                      f'{a * sample_period:g}-{b * sample_period:g}'
                      for a, b in spans[:_SHOWN_SPANS])
    more = ', ...' if len(spans) > _SHOWN_SPANS else ''
    return [Finding('samples', where,
                    f'{len(missing)} of {last + 1} samples (every {sample_period:g} s from '
                    f't = 0 to {last * sample_period:g} s) are missing, the first at t = '
                    f'{missing[0] * sample_period:g} s (missing t = {shown}{more} s)')]


def check_rows(rows: Sequence[Mapping[str, float]], duration: float, sample_period: float,
               where: str = RECOMPUTED) -> list[Finding]:
    """The ``samples`` check on metrics rows (each with its time ``'t'`` in s).

    Args:
        rows: metrics.csv rows, labelled with their sample boundary.
        duration: s, the episode's length.
        sample_period: s.
        where: what the rows are, for the finding.
    """
    return check_indices((round(row['t'] / sample_period) for row in rows),
                         last_index(duration, sample_period), sample_period, where)


def check_online(metrics: Mapping[str, Sequence[tuple[int, float]]], start_ns: int,
                 duration: float, sample_period: float) -> list[Finding]:
    """The ``samples`` check on the online /metrics/<name> samples of a bag (if it has any).

    A sample counts when every metric of the table (:data:`swarm_metrics.metrics.METRICS`)
    has it, at its boundary's log time (``start_ns + k * sample_period``).

    Args:
        metrics: name -> [(log time ns, value)], as :class:`EpisodeBag` holds them.
        start_ns: sim time of the episode's t = 0.
    """
    names = metric_names()
    if not any(metrics.get(name) for name in names):
        return []  # no online metrics recorded: nothing to check
    sample_ns = round(sample_period * 1e9)
    present = None
    for name in names:
        indices = {(t - start_ns) // sample_ns for t, _ in metrics.get(name, [])
                   if t >= start_ns and (t - start_ns) % sample_ns == 0}
        present = indices if present is None else present & indices
    return check_indices(present or set(), last_index(duration, sample_period), sample_period,
                         ONLINE)


# --- the other checks ---------------------------------------------------------------------

def check_finished(statuses: Sequence[tuple[int, dict[str, Any]]], episode: int,
                   start_ns: int = 0) -> list[Finding]:
    """The ``finished`` check: a /world/status says ``finished`` for ``episode``.

    Args:
        statuses: [(log time ns, status document)].
        episode: the episode number the announcement gives.
        start_ns: sim time of t = 0, to report times.
    """
    mine = [(t, s) for t, s in statuses if s.get('episode') == episode]
    if any(status.get('state') == 'finished' for _, status in mine):
        return []
    if mine:
        time_ns, status = mine[-1]
        last = (f'the last is {status.get("state")!r} at t = {(time_ns - start_ns) / 1e9:g} s'
                + (f' (error: {status["error"]})' if status.get('error') else ''))
    else:
        last = f'none of the {len(statuses)} recorded is for this episode'
    return [Finding('finished', STATUS,
                    f'the world never reported episode {episode} "finished" ({last}): the '
                    f'record may end before the episode did')]


def check_cleaning(statuses: Sequence[tuple[int, dict[str, Any]]], cleaning: Sequence[int],
                   episode: int,
                   start_ns: int = 0) -> list[Finding]:
    """The ``cleaning`` check: the bag holds as many /world/cleaning events up to the world's
    ``finished`` status as that status counts (``cleaning_events``; a world that does not
    count them passes). A lost event the cue maps would show only if a map follows it.

    Args:
        statuses: [(log time ns, status document)].
        cleaning: the log times (ns) of the recorded cleaning events.
        episode: the episode number the announcement gives.
        start_ns: sim time of t = 0, to report times.
    """
    final: dict[str, Any] = next((status for _, status in reversed(statuses)
                        if status.get('episode') == episode
                        and status.get('state') == 'finished'), {})
    counted, end_ns = final.get('cleaning_events'), final.get('time_ns')
    if not isinstance(counted, int) or isinstance(counted, bool):
        return []
    held = sum(1 for t in cleaning if not isinstance(end_ns, int) or start_ns <= t <= end_ns)
    if held == counted:
        return []
    return [Finding('cleaning', CLEANING,
                    f'{held} cleaning events are recorded, the world counted {counted} up to '
                    f"its end: the cue rebuilt from the record is not the world's")]


def check_cue_maps(checked: int, max_diff: int, differing: int = 0,
                   first_diff_s: float | None = None,
                   cleaning: str = 'monotone') -> list[Finding]:
    """The ``cue_maps`` check: the rebuilt cue equals every recorded /world/cue_map exactly.

    Args:
        checked: cue maps compared.
        max_diff: max |map - rint(rebuilt cue)| over them (cue units).
        differing: how many maps differ at all.
        first_diff_s: t of the first map that differs (s), if any.
        cleaning: world.cleaning; only :data:`DETERMINISTIC_CLEANING` modes are checked.
    """
    if cleaning not in DETERMINISTIC_CLEANING:
        return []
    if checked == 0:
        return [Finding('cue_maps', '/world/cue_map',
                        'no cue map recorded, so the cleaning record cannot be checked '
                        "against the world's cue (the world publishes one at its start and "
                        'at its end)')]
    if max_diff == 0:
        return []
    first = '' if first_diff_s is None else f', the first at t = {first_diff_s:g} s'
    return [Finding('cue_maps', '/world/cue_map',
                    f'{differing or "some"} of {checked} recorded cue maps differ from the cue '
                    f'rebuilt from the cleaning record by up to {max_diff} (cue units){first}: '
                    f'a /world/cleaning event is missing or wrong')]


def check_online_metrics(max_diff: float | None,
                         first: tuple[str, float] | None = None) -> list[Finding]:
    """The ``online_metrics`` check: the online samples equal the recomputation.

    Args:
        max_diff: max |online - recomputed| over the samples both have (inf for a NaN on one
            side only; None when they share none).
        first: (metric, t in s) of the first sample that differs.
    """
    if max_diff is None or max_diff == 0:
        return []
    where = '/metrics/*' if first is None else f'/metrics/{first[0]}'
    size = ('a NaN on one side only' if math.isinf(max_diff) else
            f'up to {max_diff:.3g}')
    at = '' if first is None else f', the first at t = {first[1]:g} s'
    return [Finding('online_metrics', where,
                    f"the metrics node's samples differ from the recomputation by {size}{at}")]


def check_states(states: Sequence[tuple[int, Any]], pose_times: Iterable[int],
                 start_ns: int, population: int, codes: int) -> list[Finding]:
    """The ``robot_states`` check: t = 0 and every recorded pose time have a
    /world/robot_states with one known state code per robot.

    Args:
        states: [(log time ns, uint8 [N] states)], as :class:`EpisodeBag` holds them.
        pose_times: log times (ns) of the recorded poses.
        start_ns: sim time of t = 0.
        population: N.
        codes: how many states the controller kind has (codes 0 .. codes - 1 are known).
    """
    by_time = dict(states)
    wanted = sorted({start_ns, *pose_times})
    missing = [t for t in wanted if t not in by_time]
    if missing:
        return [Finding('robot_states', ROBOT_STATES,
                        f'{len(missing)} of {len(wanted)} sampled times (t = 0 and each '
                        f'recorded pose) have no states, the first at t = '
                        f'{(missing[0] - start_ns) / 1e9:g} s')]
    for t in wanted:
        row = by_time[t]
        if len(row) != population or (len(row) and int(max(row)) >= codes):
            return [Finding('robot_states', ROBOT_STATES,
                            f'the states at t = {(t - start_ns) / 1e9:g} s are {list(row)}: '
                            f'expected {population} codes below {codes}')]
    return []


def check_sources(recorded: Sequence[tuple[int, tuple[tuple[str, float, float], ...]]],
                  expected: Any, start_ns: int) -> list[Finding]:
    """The ``sources`` check: /world/sources from t = 0, each message showing every source
    where ``expected(t)`` (s) puts it, exactly (name, x, y).

    Args:
        recorded: [(log time ns, ((name, x, y), ...))], as :class:`EpisodeBag` holds them.
        expected: t -> ((name, x, y), ...) from the announced parameters.
        start_ns: sim time of t = 0.
    """
    if not recorded or recorded[0][0] != start_ns:
        first = (f'the first at t = {(recorded[0][0] - start_ns) / 1e9:g} s' if recorded
                 else 'none recorded')
        return [Finding('sources', SOURCES, f'no /world/sources at t = 0 ({first})')]
    wrong = [(t, shown) for t, shown in recorded
             if tuple(shown) != tuple(expected((t - start_ns) / 1e9))]
    if wrong:
        t, shown = wrong[0]
        return [Finding('sources', SOURCES,
                        f'{len(wrong)} of {len(recorded)} recorded /world/sources differ from '
                        f'the announced sources, the first at t = {(t - start_ns) / 1e9:g} s: '
                        f'{list(shown)}, expected {list(expected((t - start_ns) / 1e9))}')]
    return []


def announced_sources(world: Any) -> Any:
    """t (s) -> ((name, x, y), ...) of the announced ``world`` section's sources (as
    ``CueField.source_positions`` computes them)."""
    sources = world.source_list()

    def at(t: float) -> tuple[tuple[str, float, float], ...]:
        positions = [source.position(t, world.arena_side) for source in sources]
        rows = np.array(positions, dtype=np.float64).reshape(-1, 2).tolist()
        return tuple((source.name, x, y) for source, (x, y) in zip(sources, rows))
    return at
