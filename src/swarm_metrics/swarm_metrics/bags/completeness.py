"""Is an episode's record complete? The checks every consumer of a bag runs before trusting it.

A bag can be readable and still wrong: a metrics node that started late misses the first
seconds, a lost connection leaves a gap, a world that died never says it finished, a dropped
cleaning event makes the rebuilt cue drift from the world's. Each check returns a
:class:`Finding` per failure (empty list: passed):

* ``announcement``: the /episode announcement is there and parses;
* ``finished``: the world's /world/status with ``"state": "finished"`` for the episode is there;
* ``cleaning``: every cleaning event that finished status counts is there;
* ``samples``: the metric samples start at t = 0 and miss no ``sample_period`` boundary up to
  the episode's duration (the recomputed rows, and the online /metrics/* samples if any);
* ``cue_maps``: every recorded /world/cue_map equals the cue rebuilt from the cleaning record,
  exactly (both cleaning modes are deterministic); a missing cleaning event shows up here;
* ``online_metrics``: the online /metrics/* samples equal the recomputation exactly;
* ``robot_states``: t = 0 and every recorded pose have the robots' controller states
  (/world/robot_states) at their time, one known state per robot;
* ``sources``: /world/sources is recorded from t = 0 and each shows every announced source
  exactly where the announced parameters put it at its time.

Pure Python (no ROS): the inputs are the tables of :mod:`swarm_metrics.bags.reader` and the
:class:`~swarm_metrics.bags.analysis.Recomputation`. The individual checks, which take plain
tables and numbers, are :mod:`swarm_metrics.bags.checks`.

:func:`check_bag` is *the* verdict on a bag: the recorder that closes it, the launcher that
exits 0 for a run, ``analyze``, ``replay`` and (through the findings ``analyze`` records)
``study --from-episodes`` all call it, so a bag one of them accepts, every one accepts.
:func:`check_bag_file` is the same on a bag read from disk as it is (no recovery).
"""

from __future__ import annotations

from pathlib import Path

from mona_controller.topics import ROBOT_STATES
from swarm_metrics.bags.analysis import Recomputation, episode_setup, recompute
from swarm_metrics.bags.checks import (
    Finding,
    announced_sources,
    check_cleaning,
    check_cue_maps,
    check_finished,
    check_online,
    check_online_metrics,
    check_rows,
    check_sources,
    check_states,
)
from swarm_metrics.bags.reader import EpisodeBag, read_episode_bag
from swarm_metrics.bags.scan import BagError


def check_announcement(bag: EpisodeBag) -> list[Finding]:
    """The ``announcement`` check: the bag's /episode announcement is there and parses."""
    try:
        episode_setup(bag)
    except BagError as error:
        return [Finding('announcement', '/episode', str(error))]
    return []


def check_recomputation(bag: EpisodeBag, result: Recomputation) -> list[Finding]:
    """Every check but ``announcement`` (which ``result`` implies) on a recomputed bag."""
    setup = result.setup
    start, period = setup.start_ns, setup.metrics.sample_period
    findings = check_finished(bag.status, setup.episode, start)
    findings += check_cleaning(bag.status, [t for t, _ in bag.cleaning], setup.episode, start)
    findings += check_rows(result.rows, setup.duration, period)
    findings += check_online(bag.metrics, start, setup.duration, period)
    first_map = (None if result.cue_map_first_diff_ns is None
                 else (result.cue_map_first_diff_ns - start) / 1e9)
    findings += check_cue_maps(result.cue_maps_checked, result.cue_map_max_diff,
                               result.cue_maps_differing, first_map, setup.world.cleaning)
    first_sample = (None if result.online_first_diff is None else
                    (result.online_first_diff[1], (result.online_first_diff[0] - start) / 1e9))
    findings += check_online_metrics(result.online_max_diff, first_sample)
    if setup.states:
        findings += check_states(bag.states, (t for t, _ in bag.poses), start,
                                 setup.population, len(setup.states))
    else:
        findings.append(Finding('robot_states', ROBOT_STATES, 'the announcement names no '
                                'states, and its controller kind is not registered here'))
    findings += check_sources(bag.sources, announced_sources(setup.world), start)
    return findings


def check_bag(bag: EpisodeBag, snapshot_times: tuple[float, ...] = ()
              ) -> tuple[Recomputation | None, list[Finding]]:
    """Recompute a bag's metrics and run every check: the one verdict on a bag.

    Args:
        snapshot_times: passed to :func:`~swarm_metrics.bags.analysis.recompute` (they change
            what the recomputation keeps, never the findings).

    Returns:
        (the recomputation, or None when the announcement check failed; the findings).

    Raises:
        BagError: the bag is announced but its messages contradict it (see ``recompute``).
    """
    findings = check_announcement(bag)
    if findings:
        return None, findings
    result = recompute(bag, snapshot_times)
    return result, check_recomputation(bag, result)


def check_bag_file(path: str | Path) -> list[Finding]:
    """:func:`check_bag` on the bag at ``path`` as it is on disk, read strictly (a bag that
    does not read is one ``readable`` finding): a recorder's verdict on the bag it closed, and
    the launcher's on each bag of its run."""
    try:
        return check_bag(read_episode_bag(path))[1]
    except BagError as error:
        return [Finding('readable', str(path), str(error))]
