"""``mona-swarm analyze``, ``replay`` and ``recover``: working with episode bags.

A bag the writer never closed (a killed node) is recovered automatically by ``analyze`` and
``replay`` into ``<bag>_recovered``. A bad bag gets a one-paragraph report and exit status 2.
A readable bag that fails a completeness check (:mod:`swarm_metrics.bags.completeness`: the first
seconds missing, a gap, no ``finished`` status, a cue map the cleaning record does not
rebuild, ...) is an error with exit status 1 that names the checks; with
``--allow-incomplete`` it is used anyway, and ``analyze`` records the findings in episode.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import os
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from mona_controller import plugins
from mona_controller.mappings import from_mapping
from mona_controller.schema import ParameterError
from swarm_metrics.bags import completeness
from swarm_metrics.bags.checks import Finding, describe, failed_checks
from swarm_metrics.bags.reader import EpisodeBag, find_mcap, read_episode_bag
from swarm_metrics.bags.recover import SUFFIX, default_target, recover_bag, with_recovery
from swarm_metrics.bags.scan import BagError, McapScan
from swarm_supervisor.cli.arguments import bounded, deprecated_alias
from swarm_supervisor.cli.bag_outputs import (
    ANALYSIS_SUFFIX,
    check_outputs,
    claim,
    episode_bag,
    output_folder,
)
from swarm_supervisor.config import SwarmConfig
from swarm_supervisor.engine.runner import EpisodeResult
from swarm_supervisor.outputs.location import check_location

INCOMPLETE, BAD_BAG = 1, 2  # exit statuses
#: episode.json fields of the embedded runner that a bag cannot give.
EMBEDDED_ONLY = ('encounters', 'wall_time_s', 'real_time_factor')
ALLOW_HELP = 'use a bag that fails a completeness check anyway (see docs/bags.md)'


class IncompleteBagError(Exception):
    """A readable bag that fails completeness checks; the message lists the findings.

    Args:
        path: the bag's .mcap.
        findings: the failed checks.
        hint: what the user can do about it.
        note: a note to keep with the error (e.g. that the bag was recovered).
    """

    def __init__(self, path: Path, findings: Sequence[Finding], hint: str,
                 note: str | None = None) -> None:
        self.findings = list(findings)
        checks = failed_checks(findings)
        plural = 's' if len(checks) > 1 else ''
        super().__init__(f'{path} is incomplete: it fails the {", ".join(checks)} check'
                         f'{plural}; {hint}:\n{describe(findings)}'
                         + (f'\n  note: {note}' if note else ''))


def register(subparsers) -> None:
    """Add the ``analyze``, ``replay`` and ``recover`` subcommands."""
    parser = subparsers.add_parser(
        'analyze', help='recompute the metrics of episode bags',
        description='Recompute every metric from episode bags (rosbag2 directories or .mcap '
                    'files) and write metrics.csv, episode.json, snapshots.npz and a final cue '
                    f'map PNG per bag, like `mona-swarm run`, into <bag>{ANALYSIS_SUFFIX} '
                    'beside each bag or into --out (never into the folder holding the bag, '
                    'whose own record it would overwrite). A bag whose writer was killed is '
                    'recovered first. A bag that fails a completeness check (missing seconds, '
                    'no finished status, a cue map the cleaning record does not rebuild, ...) '
                    'is an error (exit status 1) unless --allow-incomplete.')
    parser.add_argument('bags', nargs='+', type=Path, metavar='BAG',
                        help='a bag directory, its .mcap, or an episode folder holding bag/')
    parser.add_argument('--out', type=Path, metavar='DIR',
                        help='output folder (with several bags: one subfolder each); default: '
                             f'<bag>{ANALYSIS_SUFFIX} beside each bag (episode_<k>/bag'
                             f'{ANALYSIS_SUFFIX}); a folder holding a record is refused '
                             'unless --overwrite')
    parser.add_argument('--overwrite', action='store_true',
                        help='replace an output folder that holds a record whole')
    parser.add_argument('--allow-incomplete', action='store_true',
                        help=ALLOW_HELP + '; the findings go into episode.json')
    parser.set_defaults(handler=analyze)

    parser = subparsers.add_parser(
        'replay', help='play a bag back onto its ROS topics',
        description='Publish every message of a bag on its topic, with /clock, timed by the '
                    'log (sim) times divided by --pace. A bag that fails a completeness check '
                    'is an error (exit status 1) unless --allow-incomplete.')
    parser.add_argument('bag', type=Path, metavar='BAG')
    parser.add_argument('--pace', type=bounded(float, 0), default=1.0, metavar='X',
                        help='play at X times real time: X sim seconds per wall second '
                             '(default 1; 0: as fast as possible)')
    deprecated_alias(parser, '--rate', '--pace')
    parser.add_argument('--delay', type=bounded(float, 0), default=1.0, metavar='SECONDS',
                        help='wait this long for subscribers to connect before playing '
                             '(default 1)')
    parser.add_argument('--allow-incomplete', action='store_true', help=ALLOW_HELP)
    parser.set_defaults(handler=replay)

    parser = subparsers.add_parser(
        'recover', help='salvage a bag whose writer was killed',
        description='Rewrite every intact message of a bag (e.g. one without its MCAP '
                    'summary after a crash) as a valid bag, and report what was kept and '
                    'what was lost: the messages and log-time span of each damaged or '
                    "cut-off chunk, from the bag's own indexes. Exit status 0 when no "
                    'message of the file was lost, 1 when some were.')
    parser.add_argument('bag', type=Path, metavar='BAG')
    parser.add_argument('--out', type=Path, metavar='DIR',
                        help=f'the recovered bag (default: <BAG>{SUFFIX})')
    parser.set_defaults(handler=recover)


def _bad_bag(command: str, error: Exception, status: int = BAD_BAG) -> int:
    print(f'mona-swarm {command}: error: {error}', file=sys.stderr)
    return status


# --- analyze ------------------------------------------------------------------------------

def analyze(args: argparse.Namespace) -> int:
    """Recompute and write each bag's outputs; a bad or incomplete bag is reported and skipped.

    Returns:
        2 if a bag was unreadable, else 1 if one failed a completeness check, else 0.
    """
    status = 0
    try:
        bags = [episode_bag(path) for path in args.bags]
    except BagError as error:
        return _bad_bag('analyze', error)
    outs = [output_folder(bag, args.out, len(bags) > 1) for bag in bags]
    # Every output folder is checked before any bag is read: a refusal writes nothing.
    check_outputs(bags, outs, overwrite=args.overwrite, explicit=args.out is not None)
    for path, out in zip(bags, outs):
        try:
            message = analyze_bag(path, out, allow_incomplete=args.allow_incomplete,
                                  overwrite=args.overwrite)
        except IncompleteBagError as error:
            status = max(status, _bad_bag('analyze', error, INCOMPLETE))
            continue
        except BagError as error:
            status = max(status, _bad_bag('analyze', error))
            continue
        print(message)
    return status


def analyze_bag(path: Path, out: Path, *, allow_incomplete: bool = False,
                overwrite: bool = False) -> str:
    """Recompute one bag into ``out``; returns the lines to print.

    Args:
        path: the bag (directory or .mcap); a cut-short one is recovered first.
        out: the episode folder to write.
        allow_incomplete: write the outputs of a bag that fails a completeness check (the
            findings go into episode.json) instead of raising.
        overwrite: replace a record in ``out`` whole (else it is refused).

    Raises:
        BagError: the bag is unreadable.
        IncompleteBagError: it fails a completeness check (with a bad announcement, even
            when ``allow_incomplete``: there is nothing to analyse it with).
        RecordExists: ``out`` holds a record and not ``overwrite``.
        PluginError: a plug-in the bag records is missing or is not the code it recorded.
    """
    # Here, not at the top: the pictures (matplotlib) are for a bag analysed, not for --help.
    from swarm_supervisor.outputs.episode_folder import write_episode

    bag, note = with_recovery(path, read_episode_bag)
    # The run's plug-ins, the very code it ran: their metrics are recomputed, their layout
    # rebuilt (a missing or changed file is refused, naming it).
    loaded = plugins.ensure(plugins.from_records(bag.plugins, f'{bag.path}: plugins'))
    config, invalid = announced_config(bag)
    if config is not None:
        config = dataclasses.replace(config, plugins=loaded)
    snapshot_times = () if config is None else (config.study.snapshot_times
                                                + (config.episode.duration,))
    started = time.perf_counter()
    result, findings = completeness.check_bag(bag, snapshot_times)
    if result is None or config is None:
        raise IncompleteBagError(bag.path, findings if result is None else invalid,
                                 'it cannot be analysed without its announcement, even with '
                                 '--allow-incomplete', note)
    if findings and not allow_incomplete:
        raise IncompleteBagError(bag.path, findings, '--allow-incomplete analyses it anyway',
                                 note)
    setup = result.setup
    steps = (result.last_status or {}).get('step')
    episode = EpisodeResult(
        config=config, metrics=result.rows, initial_poses=setup.initial_poses,
        final_poses=result.final_poses, final_cue=result.final_cue,
        snapshots=result.snapshots, encounters=-1,
        steps=steps if isinstance(steps, int) else round(result.covered
                                                         / config.world.step_period),
        wall_time=time.perf_counter() - started)
    status = result.last_status or {}
    claim(out, overwrite=overwrite)  # only now: a failed analysis leaves a record in place
    # The embedded runner's record, less its timing, plus what a bag can tell.
    write_episode(episode, out, runner='ros', omit=EMBEDDED_ONLY, extra={
        'episode': setup.episode, 'bag': str(bag.path), 'recovered': note is not None,
        'sim_time_covered': result.covered, 'complete': not findings,
        'completeness': [finding.to_dict() for finding in findings],
        'online_metrics': {'samples': result.online_rows,
                           'max_abs_diff': result.online_max_diff},
        'cue_maps': {'checked': result.cue_maps_checked,
                     'max_abs_diff': result.cue_map_max_diff},
        'world': {key: status.get(key) for key in ('state', 'steps', 'misses', 'dropped')}})
    last = result.rows[-1]
    agreement = ('no online metrics in the bag' if result.online_max_diff is None else
                 f'online metrics agree to {result.online_max_diff:.3g}')
    checks = ', '.join(failed_checks(findings))
    text = (f'{out}: N={setup.population} seed={setup.seed}: mean cue {last["mean_cue"]:.2f} '
            f'({last["mean_cue_fraction"]:.1%} of start) after {last["t"]:g} s'
            f'{f" (INCOMPLETE: fails {checks})" if findings else ""}; '
            f'{agreement}; {result.cue_maps_checked} cue maps match the rebuilt cue to '
            f'{result.cue_map_max_diff}')
    if findings:
        text += f'\n{describe(findings)}'
    return text + (f'\n  note: {note}' if note else '')


def announced_config(bag: EpisodeBag) -> tuple[SwarmConfig | None, list[Finding]]:
    """The run's whole configuration from the bag's announcement: (config, []), or (None,
    an ``announcement`` finding) when it is missing or its parameters are not this version's
    (the completeness checks read only the sections a recomputation needs)."""
    parameters = (bag.announcement or {}).get('parameters')
    try:
        return from_mapping(SwarmConfig, parameters), []
    except (ParameterError, TypeError, AttributeError) as error:
        return None, [Finding('announcement', '/episode',
                              f'{bag.path}: the announced parameters are invalid: {error}')]


# --- recover ------------------------------------------------------------------------------

def recover(args: argparse.Namespace) -> int:
    """Salvage a bag and report what was kept and what was lost.

    Returns:
        0 when every message of the source file is in the recovered bag, 1 when some were
        lost (a damaged or cut-off chunk, a message of an unknown type), 2 when nothing
        could be recovered.
    """
    if args.out is not None or Path(args.bag).exists():  # a missing bag is said below
        target = args.out or default_target(Path(args.bag))
        check_location(target, '--out' if args.out is not None else '--out (default)')
    try:
        report = recover_bag(args.bag, args.out)
    except BagError as error:
        return _bad_bag('recover', error)
    print(report.summary())
    return INCOMPLETE if report.anything_lost else 0


# --- replay -------------------------------------------------------------------------------

def checked_mcap(path: Path) -> tuple[Path, dict[str, str]]:
    """The bag's .mcap after a full strict read, and its topics -> types."""
    scan = McapScan(find_mcap(path))
    for _ in scan:
        pass
    return scan.path, {topic.topic: topic.msgtype for topic in scan.topics.values()}


def check_rmw() -> None:
    """``RMW_IMPLEMENTATION``, if set, names an installed ROS middleware (each comes with a
    Python package of its name).

    Raises:
        ParameterError: naming the variable and what is installed.
    """
    name = os.environ.get('RMW_IMPLEMENTATION', '')
    if name and (not name.isidentifier() or importlib.util.find_spec(name) is None):
        raise ParameterError(f'RMW_IMPLEMENTATION={name}: no such ROS middleware is installed '
                             '(rmw_fastrtps_cpp is): unset it')


def replay(args: argparse.Namespace) -> int:
    """Publish the bag's messages on their topics, timed by their log times.

    Returns:
        0 once played; 2 for an unreadable bag; 1 for one that fails a completeness check
        (unless ``--allow-incomplete``).
    """
    check_rmw()  # before rclpy is imported: rcl ends the process over an unknown one
    from swarm_supervisor.system.ros.replay import check_ros_environment, play  # needs ROS

    check_ros_environment()
    try:
        (mcap, topics), note = with_recovery(args.bag, checked_mcap)
        findings = completeness.check_bag(read_episode_bag(mcap))[1]
    except BagError as error:
        return _bad_bag('replay', error)
    if findings:
        hint = ('replaying it anyway (--allow-incomplete)' if args.allow_incomplete
                else '--allow-incomplete replays it anyway')
        incomplete = IncompleteBagError(mcap, findings, hint, note)
        if not args.allow_incomplete:
            return _bad_bag('replay', incomplete, INCOMPLETE)
        print(f'warning: {incomplete}', file=sys.stderr)
    elif note:
        print(f'note: {note}', file=sys.stderr)
    try:
        count, publishers, span, wall = play(mcap, topics, rate=args.pace, delay=args.delay)
    except BagError as error:
        return _bad_bag('replay', error)
    print(f'replayed {count} messages on {publishers} topics from {mcap}: {span:.3f} '
          f's of sim time in {wall:.1f} s')
    return 0
