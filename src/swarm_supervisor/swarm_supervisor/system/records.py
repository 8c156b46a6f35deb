"""The launcher's verdict on a run's records: each episode's bag, judged as it is on disk.

The supervisor ends a run with status 0 only when every recorder reported its record of
every episode complete, and a recorder's report is the verdict of
:func:`swarm_metrics.bags.completeness.check_bag` on the bag it closed. The launcher judges every
bag that ``run.json`` lists once more with that same function when the run is over, so its
exit status and ``mona-swarm analyze``'s answer on those bags cannot differ. The live view's
word (recorder ``live``) names no file and is not judged here.
"""

from __future__ import annotations

import json
from pathlib import Path

RUN_FILE = 'run.json'  #: the supervisor's record of the run, in its output folder
#: The live node's name on /recorders: it says there when it holds an episode's final state
#: (a word, not a file: there is no bag of it to judge).
LIVE_RECORDER = 'live'


def incomplete_records(out: Path) -> list[str]:
    """What is wrong with the records of the run in ``out``: one text per bag that fails the
    completeness verdict (naming the bag, the episode and every finding), or that
    ``run.json`` is missing or lists an episode without a record. Empty: all complete.
    """
    from swarm_metrics.bags.checks import describe, failed_checks
    from swarm_metrics.bags.completeness import check_bag_file

    try:
        episodes = json.loads((out / RUN_FILE).read_text())['episodes']
    except (OSError, ValueError, KeyError, TypeError) as error:
        return [f'{out / RUN_FILE} does not list the episodes and their records ({error})']
    problems = []
    for episode in episodes:
        records = episode.get('records') or {}
        if not set(records) - {LIVE_RECORDER}:
            problems.append(f'episode {episode.get("episode")} has no record in '
                            f'{out / RUN_FILE}')
        for recorder, record in sorted(records.items()):
            if recorder == LIVE_RECORDER:
                continue
            findings = check_bag_file(Path(record['path']))
            if findings:
                checks = ', '.join(failed_checks(findings))
                problems.append(f'{record["path"]} (episode {episode.get("episode")}, '
                                f'recorder {recorder}) is incomplete: it fails the {checks} '
                                f'check(s):\n{describe(findings)}')
    return problems
