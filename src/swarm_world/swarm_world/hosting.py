"""What a world node decides about an episode, without ROS (docs/interfaces.md, "Stepping"
and "Recorders").

The world node (:mod:`swarm_world.ros.world_node`) keeps the topics and the timers; here is
what it decides with them, in plain Python: whether it can play an announced episode
(:func:`unplayable`), what it says when the controllers or the recorders do not
come (:func:`unconnected`, :func:`unconfirmed`), how far its recorders must have recorded
before it steps on and what it says when they do not (:func:`hold_until_ns`,
:func:`hold_failure`), and the final state it writes for parity checks
(:func:`write_final`). The driver node is a world node and decides the same way.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mona_controller.contract import Announcement
from mona_controller.mappings import differences, to_mapping
from mona_controller.topics import RECORDERS

if TYPE_CHECKING:
    from swarm_world.lockstep import Lockstep
    from swarm_world.world import World

#: The final state of an episode, in ``<output_dir>/episode_<k>/``.
FINAL_FILE = 'world_final.npz'


def unplayable(announcement: Announcement, time_ns: int,
               sections: Mapping[str, Any]) -> str:
    """What a world at sim time ``time_ns`` whose parameters are ``sections`` (``world``,
    ``mona``, ``sensing``: name -> section) cannot play of a well-formed announcement ('' =
    nothing)."""
    if announcement.population < 1:
        return 'no robots'
    if announcement.start_ns < time_ns:
        return (f'start_ns {announcement.start_ns} is before the world time '
                f'{time_ns}: sim time must not run backwards')
    try:
        announcement.robot_states()  # what the robots' markers are coloured by
    except KeyError as error:
        return f'no controller states announced, and {error.args[0]}'
    for section, mine in sections.items():
        theirs = announcement.parameters.get(section)
        # As parameters (defaults applied), naming the keys that differ.
        differ = [] if theirs is None else differences(mine, theirs, f'{section}.')
        if differ:
            return (f'the announced {section} parameters differ from the world '
                    "node's: " + '; '.join(differ)
                    + ': start every node with the same --params-file')
    return ''


def unconnected(episode: int, timeout: float, missing: Sequence[int], population: int) -> str:
    """The error of an episode whose robots ``missing`` had no controller after ``timeout``
    wall seconds."""
    shown = ', '.join(str(i) for i in missing[:20]) + (', ...' if len(missing) > 20 else '')
    return (f'episode {episode}: after {timeout:g} s no controller connected for '
            f'{len(missing)} of {population} robots ({shown}); start a mona_controller_node '
            f'for each of /mona_0 .. /mona_{population - 1}')


def unconfirmed(episode: int, timeout: float, recorders: Sequence[str]) -> str:
    """The error of an episode whose ``recorders`` did not say they record it within
    ``timeout`` wall seconds."""
    return (f'episode {episode}: after {timeout:g} s the recorder(s) {", ".join(recorders)} '
            f'did not confirm that they record the episode on {RECORDERS}; is the '
            f'metrics_node running and alive?')


def hold_until_ns(start_ns: int, time_ns: int, lag: float) -> int:
    """The sim time every recorder's record must reach before the world steps on from
    ``time_ns``: the episode's start (keep-last-1 topics that the next map would overwrite),
    and in lockstep (``lag`` > 0 s of sim time) no more than ``lag`` behind (a recorder's
    subscriptions keep a bounded history)."""
    lag_ns = round(lag * 1e9)
    return start_ns if lag_ns == 0 else max(start_ns, time_ns - lag_ns)


def hold_failure(episode: int, behind: Sequence[str], at_start: bool, lag: float,
                 timeout: float) -> str:
    """The error of an episode whose recorders ``behind`` did not record its start
    (``at_start``), or did not catch up, within ``timeout`` wall seconds."""
    how = ("did not record the episode's start (t = 0's poses, states, cue map and "
           'sources)' if at_start else
           f'fell more than {lag:g} s of sim time behind and did not catch up')
    return (f'episode {episode}: the recorder(s) {", ".join(behind)} {how} within '
            f'{timeout:g} s; is the metrics_node alive?')


def write_final(folder: Path, world: World, lockstep: Lockstep, *, seed: int, episode: int,
                time_ns: int, start_ns: int, sections: Mapping[str, Any]) -> None:
    """``folder``/:data:`FINAL_FILE`: an episode's final state (poses, cue, the lockstep
    counters, its seed, times and parameters ``sections``), written whole or not at all."""
    folder.mkdir(parents=True, exist_ok=True)
    partial_path = folder / (FINAL_FILE + '.partial.npz')
    np.savez(partial_path, poses=world.poses.astype(np.float64),
             cue=world.cue.astype(np.float32), misses=lockstep.misses,
             dropped=np.int64(lockstep.dropped), duplicates=np.int64(lockstep.duplicates),
             seed=np.int64(seed), episode=np.int64(episode), steps=np.int64(world.steps),
             time_ns=np.int64(time_ns), start_ns=np.int64(start_ns),
             parameters=json.dumps({name: to_mapping(section)
                                    for name, section in sections.items()}))
    os.replace(partial_path, folder / FINAL_FILE)
