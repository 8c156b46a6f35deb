"""Mistakes with the node system (``scripts/swarm.sh``, ``mona-swarm launch``): each is refused
before a node starts, in one line naming the option and the fix, with nothing written in
``--out``, within :data:`REFUSED_WITHIN`."""

from __future__ import annotations

from pathlib import Path

from mistake import SWARM_SH, Mistake

#: A refusal starts no node: it takes a Python start and the checks, never a run (about 2 s
#: on an idle 2-core machine). The bound is a hang's, not a speed claim: four test workers on
#: 2 cores took over 10 s in CI.
REFUSED_WITHIN = 30.0


def earlier_node_run(tmp: Path) -> None:
    """A folder holding an earlier node-system run: run.json and episode 0's bag."""
    bag = tmp / 'earlier' / 'episode_0' / 'bag'
    bag.mkdir(parents=True)
    (bag / 'metadata.yaml').write_text('rosbag2_bagfile_information:\n  version: 9\n')
    (tmp / 'earlier' / 'run.json').write_text('{"runner": "ros", "episodes": []}\n')


def refused(name: str, args: list[str], pattern: str, **more) -> Mistake:
    """A row: ``scripts/swarm.sh ARGS --out {tmp}/new`` exits 2 matching ``pattern``."""
    more.setdefault('unchanged', ('new',))
    out = [] if '--out' in args else ['--out', '{tmp}/new']
    return Mistake(name, [SWARM_SH, *args, *out], 2, pattern, timeout=REFUSED_WITHIN, **more)


CASES = [
    refused('launch-population-too-large', ['--population', '2000'],
            r'--population 2000 does not fit .*give a smaller --population'),
    refused('launch-too-many-participants', ['--population', '200'],
            r'203 DDS participants.*--controllers-per-process 2'),
    refused('launch-domain-232-too-small', ['--population', '100', '--domain', '232'],
            r'103 DDS participants.*fit domain 232.*--controllers-per-process 2'),
    refused('launch-bad-swarm-domain-id', ['--population', '3'],
            r"SWARM_DOMAIN_ID 'x': expected 0\.\.232", env={'SWARM_DOMAIN_ID': 'x'}),
    refused('launch-domain-233', ['--population', '3', '--domain', '233'], r'--domain.*233'),
    refused('launch-speed-300', ['--speed', '300'], r'controller\.speed = 3\.0 is out of range'),
    refused('launch-linger-without-live', ['--population', '3', '--linger', '5'],
            r'--linger is for --live'),
    refused('launch-core-without-domain', ['--role', 'core'],
            r'--role core: give --domain ID'),
    refused('launch-over-a-run', ['--population', '3', '--out', '{tmp}/earlier'],
            r'earlier already holds .*--overwrite', setup=earlier_node_run,
            unchanged=('earlier',)),
]
