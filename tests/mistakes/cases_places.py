"""Mistakes in where a command writes or what it reaches, refused before its first step with
nothing written: an output under a file or on a pseudo file system, a folder another command
is writing, a live-view port already taken, a scheduler address that is none or does not
answer, a ROS environment rcl refuses; and an old option name, which still works but warns."""

from __future__ import annotations

import sys
from pathlib import Path

from cases_inputs import BUILT_WITHIN
from cases_run import TINY, a_file
from cases_study import design
from mistake import MONA_SWARM, SWARM_SH, Mistake

OCCUPIED = [sys.executable, str(Path(__file__).with_name('occupied.py'))]
EVOLVE = '{repo}/ros_ws/config/designs/evolve.yaml'
CALIBRATE = '{repo}/ros_ws/config/designs/calibration.yaml'
#: Nothing written anywhere in the scratch folder (the row's own files stay as they were).
NEW = {'unchanged': ('.',)}
#: A scheduler port nothing listens on (connections are refused at once).
CLOSED = 'tcp://127.0.0.1:1'


def tiny_bag(tmp: Path) -> None:
    """A tiny embedded run with its bag in tmp/run."""
    import subprocess
    subprocess.run([MONA_SWARM, 'run', *TINY, '--bag', '--out', str(tmp / 'run')], check=True,
                   capture_output=True)


CASES = [
    # Output locations that cannot take the output.
    Mistake('run-out-under-a-file', [MONA_SWARM, 'run', *TINY, '--out', '{tmp}/notes.txt/run'],
            2, r'--out \S*notes\.txt/run lies under \S*notes\.txt, which is a file, not a folder',
            setup=a_file, **NEW),
    Mistake('run-out-in-proc', [MONA_SWARM, 'run', *TINY, '--out', '/proc/mona-run'], 2,
            r'--out /proc/mona-run is on /proc, a proc file system .*choose a folder on a disk',
            **NEW),
    Mistake('study-out-in-sys', [MONA_SWARM, 'study', '--config', '{tmp}/tiny.yaml', '--out',
                                 '/sys/mona-study'], 2,
            r'--out /sys/mona-study is on /sys, a sysfs file system', setup=design('tiny'),
            timeout=BUILT_WITHIN, **NEW),
    Mistake('launch-out-in-proc', [SWARM_SH, '--population', '3', '--out', '/proc/mona-ros'], 2,
            r'--out /proc/mona-ros is on /proc, a proc file system', timeout=BUILT_WITHIN,
            **NEW),
    Mistake('analyze-out-under-a-file', [MONA_SWARM, 'analyze', '{tmp}/run/bag', '--out',
                                         '{tmp}/notes.txt/analysis'], 2,
            r'--out \S*notes\.txt/analysis lies under \S*notes\.txt, which is a file',
            setup=lambda tmp: (tiny_bag(tmp), a_file(tmp)), **NEW),
    Mistake('recover-out-in-proc', [MONA_SWARM, 'recover', '{tmp}/run/bag', '--out',
                                    '/proc/mona-recovered'], 2,
            r'--out /proc/mona-recovered is on /proc', setup=tiny_bag, **NEW),
    Mistake('animate-out-under-a-file', [MONA_SWARM, 'animate', '{tmp}/run', '--out',
                                         '{tmp}/notes.txt/n3.gif'], 2,
            r'--out \S*notes\.txt/n3\.gif lies under \S*notes\.txt, which is a file',
            setup=lambda tmp: (tiny_bag(tmp), a_file(tmp)), **NEW),
    Mistake('calibrate-out-in-proc', [MONA_SWARM, 'calibrate', CALIBRATE, '--out',
                                      '/proc/mona-calibration'], 2,
            r'--out /proc/mona-calibration is on /proc', timeout=BUILT_WITHIN, **NEW),
    Mistake('evolve-out-under-a-file', [MONA_SWARM, 'evolve', EVOLVE, '--out',
                                        '{tmp}/notes.txt/evolve'], 2,
            r'--out \S*notes\.txt/evolve lies under \S*notes\.txt, which is a file',
            setup=a_file, timeout=BUILT_WITHIN, **NEW),
    # Two studies started into one folder at once: one runs, the other is refused; the
    # folder holds one complete study, run once.
    Mistake('study-twice-into-one-folder-at-once',
            ['sh', '-c', ' '.join(OCCUPIED) + f' twice {MONA_SWARM} study --config '
             '{tmp}/tiny.yaml --out {tmp}/one --jobs 1 && test -f {tmp}/one/report.md && '
             'grep -c \'"started"\' {tmp}/one/study.json'], 0,
            r'(?s)exit status 2\n.*--out \S*one is being written by another process.*'
            r'wait until it ends.*\n1\n?\Z', setup=design('tiny'), timeout=600),
    # A live view's port that is taken: refused before the run (it would fail at its end).
    Mistake('launch-live-port-taken',
            [*OCCUPIED, 'port', SWARM_SH, '--population', '3', '--duration', '2', '--live',
             '--live-port', 'PORT', '--out', '{tmp}/new'], 2,
            r'--live-port \d+: 127\.0\.0\.1:\d+ is taken .*give another --live-port, or 0',
            timeout=BUILT_WITHIN, **NEW),
    Mistake('run-live-port-taken',
            [*OCCUPIED, 'port', MONA_SWARM, 'run', *TINY, '--live', '--live-port', 'PORT',
             '--out', '{tmp}/new'], 2, r'the live view cannot listen on 127\.0\.0\.1:\d+',
            **NEW),
    # Scheduler addresses: not one (refused at once), or one that does not answer (refused
    # before --out is created).
    Mistake('study-scheduler-not-an-address',
            [MONA_SWARM, 'study', '--config', '{tmp}/tiny.yaml', '--scheduler', 'head-node',
             '--out', '{tmp}/new'], 2,
            r'--scheduler head-node: no port: give tcp://HOST:PORT', setup=design('tiny'),
            timeout=BUILT_WITHIN, **NEW),
    Mistake('study-scheduler-unreachable',
            [MONA_SWARM, 'study', '--config', '{tmp}/tiny.yaml', '--scheduler', CLOSED,
             '--scheduler-timeout', '1', '--out', '{tmp}/new'], 2,
            r'cannot reach the Dask scheduler at tcp://127\.0\.0\.1:1', setup=design('tiny'),
            timeout=BUILT_WITHIN, **NEW),
    Mistake('calibrate-scheduler-unknown-host',
            [MONA_SWARM, 'calibrate', CALIBRATE, '--scheduler', 'tcp://no-such-host.invalid:8786',
             '--out', '{tmp}/new'], 2,
            r'--scheduler tcp://no-such-host\.invalid:8786: the host no-such-host\.invalid is '
            r'unknown', timeout=BUILT_WITHIN, **NEW),
    Mistake('evolve-scheduler-unreachable',
            [MONA_SWARM, 'evolve', EVOLVE, '--scheduler', CLOSED, '--scheduler-timeout', '1',
             '--out', '{tmp}/new'], 2,
            r'cannot reach the Dask scheduler at tcp://127\.0\.0\.1:1',
            timeout=BUILT_WITHIN, **NEW),
    # The ROS environment: what rcl would refuse, or end the process over.
    Mistake('replay-ros-domain-id-not-a-number',
            [MONA_SWARM, 'replay', '{tmp}/run/bag', '--pace', '0', '--delay', '0'], 2,
            r'the ROS environment is not usable: ROS_DOMAIN_ID is not an integral number',
            setup=tiny_bag, env={'ROS_DOMAIN_ID': 'seven'}, **NEW),
    Mistake('replay-unknown-middleware',
            [MONA_SWARM, 'replay', '{tmp}/run/bag', '--pace', '0', '--delay', '0'], 2,
            r'RMW_IMPLEMENTATION=rmw_cyclone_cpp: no such ROS middleware is installed',
            setup=tiny_bag, env={'RMW_IMPLEMENTATION': 'rmw_cyclone_cpp'},
            **NEW),
    Mistake('launch-fastdds-profile-missing', [SWARM_SH, '--population', '3', '--out',
                                               '{tmp}/new'], 2,
            r'SWARM_FASTDDS_PROFILE=\S*nowhere\.xml: cannot read it',
            env={'SWARM_FASTDDS_PROFILE': '{tmp}/nowhere.xml'}, timeout=BUILT_WITHIN, **NEW),
    # An old option name: it works, and says the new one.
    Mistake('replay-old-rate-option',
            [MONA_SWARM, 'replay', '{tmp}/run/bag', '--rate', '0', '--delay', '0'], 0,
            r'warning: --rate is deprecated and will be removed: use --pace(?s:.*)replayed \d+ '
            r'messages', setup=tiny_bag, **NEW),
]
