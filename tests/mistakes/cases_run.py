"""Mistakes with ``mona-swarm run``, ``analyze``, ``recover`` and ``animate``."""

from __future__ import annotations

import subprocess
from pathlib import Path

from mistake import MONA_SWARM, Mistake

TINY = ['--population', '3', '--duration', '2']  # a run of about a second


def earlier_run(tmp: Path) -> None:
    """A folder holding an earlier embedded run (a tiny one)."""
    subprocess.run([MONA_SWARM, 'run', *TINY, '--out', str(tmp / 'earlier')], check=True,
                   capture_output=True)


def recorded_run(tmp: Path) -> None:
    """An embedded run with its bag (tmp/run/bag, chunks every 5 s: 3 chunks), and the
    sha256 sums of its own record in tmp/sums (for ``sha256sum -c``)."""
    run = tmp / 'run'
    subprocess.run([MONA_SWARM, 'run', '--population', '3', '--duration', '12', '--bag',
                    '--out', str(run)], check=True, capture_output=True)
    sums = subprocess.run(['sha256sum', 'episode.json', 'metrics.csv', 'snapshots.npz',
                           'final_cue_map.png'], cwd=run, check=True, capture_output=True,
                          text=True).stdout
    (tmp / 'sums').write_text(sums)


def analysed_run(tmp: Path) -> None:
    """A recorded run already analysed into its default folder (run/bag.analysis)."""
    recorded_run(tmp)
    subprocess.run([MONA_SWARM, 'analyze', str(tmp / 'run' / 'bag')], check=True,
                   capture_output=True)


def damaged_run(tmp: Path) -> None:
    """A recorded run whose bag has one damaged chunk (a flipped byte in the fullest)."""
    from mcap.reader import make_reader

    recorded_run(tmp)
    mcap = tmp / 'run' / 'bag' / 'bag.mcap'
    with open(mcap, 'rb') as handle:
        fullest = max(make_reader(handle).get_summary().chunk_indexes,
                      key=lambda entry: entry.chunk_length)
    data = bytearray(mcap.read_bytes())
    data[fullest.chunk_start_offset + fullest.chunk_length // 2] ^= 0x10
    mcap.write_bytes(bytes(data))


def two_runs_named_alike(tmp: Path) -> None:
    """Two recorded runs whose episode folders have one name (one/ep, two/ep)."""
    for name in ('one', 'two'):
        subprocess.run([MONA_SWARM, 'run', *TINY, '--bag', '--out', str(tmp / name / 'ep')],
                       check=True, capture_output=True)


def flat_config(tmp: Path) -> None:
    """A parameter file whose keys are not under '/**', 'ros__parameters' and sections."""
    (tmp / 'flat.yaml').write_text('population: 3\nspeed: 0.08\n')


def speed_in_cm(tmp: Path) -> None:
    """A parameter file giving controller.speed in cm/s (the file takes m/s)."""
    (tmp / 'cm.yaml').write_text('/**:\n  ros__parameters:\n    controller: {speed: 8}\n')


def empty_arena(tmp: Path) -> None:
    """A parameter file asking for no robots."""
    (tmp / 'empty.yaml').write_text('/**:\n  ros__parameters:\n    episode: {population: 0}\n')


def a_file(tmp: Path) -> None:
    """A plain file where an output folder would go."""
    (tmp / 'notes.txt').write_text('my notes\n')


def earlier_video(tmp: Path) -> None:
    """A recorded run and, in tmp/videos, a video made earlier (stand-in bytes)."""
    recorded_run(tmp)
    (tmp / 'videos').mkdir()
    (tmp / 'videos' / 'n3.gif').write_bytes(b'GIF89a earlier video')


def run_in(folder: str, *options: str) -> list[str]:
    """``mona-swarm run`` of a tiny episode into ``{tmp}/<folder>``."""
    return [MONA_SWARM, 'run', *TINY, *options, '--out', '{tmp}/' + folder]


#: Every file of the run's own record byte-identical after the command (sha256sum -c).
CHECK_SUMS = '&& cd {tmp}/run && sha256sum -c {tmp}/sums'

CASES = [
    Mistake('run-over-a-run', run_in('earlier'),
            2, r'earlier.*holds.*--overwrite', setup=earlier_run, unchanged=('earlier',)),
    Mistake('run-population-too-large', [MONA_SWARM, 'run', '--population', '2000',
                                         '--out', '{tmp}/new'],
            2, r'does not fit.*smaller population \(at most \d+ fit\).*bigger '
               r'world\.arena_side \(at least [\d.]+ m', unchanged=('new',)),
    Mistake('run-population-too-large-over-a-run',
            [MONA_SWARM, 'run', '--population', '2000', '--overwrite', '--out',
             '{tmp}/earlier'],
            2, r'does not fit', setup=earlier_run, unchanged=('earlier',)),
    Mistake('run-repeated-seed', run_in('new', '--seed', '1', '1'),
            2, r'--seed 1 1 repeats seed 1', unchanged=('new',)),
    Mistake('run-population-0', [MONA_SWARM, 'run', '--population', '0', '--out',
                                 '{tmp}/new'],
            2, r'--population = 0: an episode needs at least one robot', unchanged=('new',)),
    Mistake('run-population-0-in-the-yaml',
            [MONA_SWARM, 'run', '--config', '{tmp}/empty.yaml', '--out', '{tmp}/new'],
            2, r'empty\.yaml: episode\.population = 0: an episode needs at least one robot',
            setup=empty_arena, unchanged=('new',)),
    Mistake('run-speed-in-m-per-s', run_in('new', '--speed', '0.08'),
            2, r'0\.08 cm/s looks like m/s: give cm/s, e.g\. --speed 8', unchanged=('new',)),
    Mistake('run-yaml-speed-in-cm-per-s', run_in('new', '--config', '{tmp}/cm.yaml'),
            2, r'cm\.yaml: controller\.speed = 8\.0 is out of range.*m/s \(8 cm/s = 0\.08\)',
            setup=speed_in_cm, unchanged=('new',)),
    # the file named once, the misplaced keys' sections, then the skeleton
    Mistake('run-flat-yaml', run_in('new', '--config', '{tmp}/flat.yaml'),
            2, r'(?s)\A(?!(?:.*flat\.yaml){2}).*flat\.yaml: expected a ROS 2 parameter file.*'
               r'episode\.population, controller\.speed.*skeleton:\n.*/\*\*:\n.*'
               r'ros__parameters:\n.*episode: \{population',
            setup=flat_config, unchanged=('new',)),
    Mistake('run-missing-config', run_in('new', '--config', '{tmp}/nowhere.yaml'),
            2, r'cannot read .*nowhere\.yaml: No such file', unchanged=('new',)),
    Mistake('run-out-is-a-file', run_in('notes.txt'),
            2, r'--out .*notes\.txt is a file, not a folder', setup=a_file),
    Mistake('run-bad-duration', run_in('new', '--duration', '0'),
            2, r'episode\.duration = 0\.0 is out of range', unchanged=('new',)),
    # analyze writes beside the bag, into run/bag.analysis: the run's record stays as it was
    Mistake('analyze-a-run-without-out',
            ['sh', '-c', MONA_SWARM + ' analyze {tmp}/run/bag ' + CHECK_SUMS],
            0, r'bag\.analysis: N=3 seed=1(?s:.*)episode\.json: OK(?s:.*)snapshots\.npz: OK',
            setup=recorded_run, unchanged=('run/bag',)),
    Mistake('analyze-an-episode-folder',
            ['sh', '-c', MONA_SWARM + ' analyze {tmp}/run ' + CHECK_SUMS],
            0, r'run/bag\.analysis: N=3(?s:.*)episode\.json: OK', setup=recorded_run,
            unchanged=('run/bag',)),
    Mistake('analyze-again', [MONA_SWARM, 'analyze', '{tmp}/run/bag'],
            2, r'bag\.analysis already holds an episode.*--overwrite', setup=analysed_run,
            unchanged=('run',)),
    Mistake('analyze-into-the-run', [MONA_SWARM, 'analyze', '{tmp}/run/bag', '--out',
                                     '{tmp}/run', '--overwrite'],
            2, r'--out .*run holds the bag being analysed', setup=recorded_run,
            unchanged=('run',)),
    Mistake('analyze-two-bags-into-one-folder',
            [MONA_SWARM, 'analyze', '{tmp}/one/ep/bag', '{tmp}/two/ep/bag', '--out',
             '{tmp}/analysed'],
            2, r'one/ep/bag and .*two/ep/bag would both be analysed into .*analysed/ep',
            setup=two_runs_named_alike, unchanged=('one', 'two', 'analysed')),
    Mistake('analyze-a-damaged-bag', [MONA_SWARM, 'analyze', '{tmp}/run/bag'],
            2, r'chunk at byte \d+ is damaged.*`mona-swarm recover`', setup=damaged_run,
            unchanged=('run',)),
    Mistake('analyze-no-bag', [MONA_SWARM, 'analyze', '{tmp}/earlier'],
            2, r'earlier holds no bag.*mona-swarm run --bag', setup=earlier_run,
            unchanged=('earlier',)),
    Mistake('recover-a-damaged-bag', [MONA_SWARM, 'recover', '{tmp}/run/bag'],
            1, r'LOST \d+ messages of the \d+ the source\'s summary counts in 1 chunk: the '
               r'damaged chunk at byte \d+: \d+ messages logged t = [\d.]+ to [\d.]+ s',
            setup=damaged_run, unchanged=('run/bag',)),  # the copy goes to run/bag_recovered
    Mistake('recover-a-whole-bag', [MONA_SWARM, 'recover', '{tmp}/run/bag'],
            0, r'the source bag was complete, nothing was lost', setup=recorded_run,
            unchanged=('run/bag',)),
    Mistake('animate-over-a-video', [MONA_SWARM, 'animate', '{tmp}/run', '--out',
                                     '{tmp}/videos/n3.gif'],
            2, r'--out .*n3\.gif exists: choose another --out, or pass --overwrite',
            setup=earlier_video, unchanged=('videos', 'run')),
    Mistake('animate-into-a-folder', [MONA_SWARM, 'animate', '{tmp}/run', '--out',
                                      '{tmp}/videos'],
            2, r'--out .*videos is a folder', setup=earlier_video,
            unchanged=('videos', 'run')),
]
