"""``mona-swarm study``: run the paper's study (or analyse existing episodes) into one folder."""

from __future__ import annotations

import argparse
import dataclasses
import signal
import sys
import time
from pathlib import Path

from swarm_supervisor import exits, study
from swarm_supervisor.cli.arguments import bounded


def register(subparsers) -> None:
    """Add the ``study`` subcommand."""
    parser = subparsers.add_parser(
        'study', help='run the study (populations x speeds x seeds) and write its report',
        description='Run every episode of the study section of the parameter file in parallel '
                    '(resuming a partly finished --out), then write all_metrics.csv, figures '
                    '3-6, the ANOVA tables and report.md into --out. With --from-episodes, '
                    'run nothing and analyse the episode folders found there instead (e.g. '
                    'from `mona-swarm analyze` on ROS bags). Ctrl-C or SIGTERM stops at once: '
                    'finished episodes are kept, the running batches are cut, and the same '
                    'command resumes. See docs/study.md.',
        epilog=exits.HELP + '.')
    parser.add_argument('--out', type=Path, required=True, metavar='DIR',
                        help='output folder (created; a study of the same design in it is '
                             'resumed; one of another design, or another record, is refused '
                             'unless --overwrite)')
    parser.add_argument('--overwrite', action='store_true',
                        help='delete whatever record --out holds (a study, a run, a bag) '
                             'and start over')
    parser.add_argument('--config', type=Path, metavar='YAML',
                        help='ROS 2 parameter file whose study section is the design '
                             '(default: ros_ws/config/mona_swarm.yaml)')
    parser.add_argument('--quick', action='store_true',
                        help='a reduced design for a smoke test: N = 5 and 10, the same '
                             'speeds, the first two seeds, 60 s episodes')
    parser.add_argument('--jobs', type=bounded(int, 1), metavar='J',
                        help='worker processes (default: one per CPU)')
    parser.add_argument('--batch-size', type=bounded(int, 1), metavar='B',
                        help='episodes each worker steps together (default: '
                             f'{study.DEFAULT_BATCH_SIZE}; 1: one at a time); the outputs are '
                             'the same for any size')
    parser.add_argument('--bag', action='store_true',
                        help="record each episode's bag (the metrics node's record: analyze, "
                             'replay, animate and Foxglove read it) in its folder')
    parser.add_argument('--videos', action='store_true',
                        help='also render one MP4 per design cell (its first seed) into '
                             'DIR/videos (implies --bag)')
    parser.add_argument('--scheduler', metavar='ADDRESS',
                        help='run the episodes on the workers of this Dask distributed '
                             'scheduler (e.g. tcp://10.0.0.1:8786) instead of local processes; '
                             'see "The study on a cluster" in docs/study.md')
    parser.add_argument('--scheduler-timeout', type=bounded(float, 0.1), default=30.0,
                        metavar='SECONDS',
                        help='how long to wait for the scheduler to answer (default: 30)')
    parser.add_argument('--from-episodes', type=Path, nargs='+', metavar='DIR',
                        help='analyse the episode folders (metrics.csv + episode.json) at or '
                             'under these folders; run nothing')
    parser.add_argument('--allow-incomplete', action='store_true',
                        help='with --from-episodes: analyse episodes whose record is '
                             'incomplete (a gap, no finished status, ...) anyway; report.md '
                             'lists them and what they lack')
    parser.add_argument('--claims', type=Path, action='append', default=[], metavar='YAML',
                        help="claims of your own to check beside the paper's (repeatable; "
                             'format: swarm_supervisor/paper_claims.yaml)')
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Run (or collect) the episodes, then write the figures, tables and report.

    Returns:
        0; 1 when --from-episodes finds an incomplete episode (without --allow-incomplete);
        130 / 143 when SIGINT / SIGTERM stopped the episodes (the kept ones are said).
    """
    # Here, not at the top: ``--help`` and a refused argument need no analysis libraries.
    import pandas as pd

    from swarm_supervisor.analysis.claims import all_claims
    from swarm_supervisor.analysis.report import analyse
    from swarm_supervisor.config import load_config

    started = time.perf_counter()
    if args.from_episodes:
        return from_episodes(args, started)
    if args.allow_incomplete:
        raise study.StudyError('--allow-incomplete applies to --from-episodes only (the '
                               'episodes a study runs are complete)')
    config = load_config(args.config)  # with its plug-ins, whose metrics a claim may test
    all_claims(args.claims)  # a bad claims file fails now, not after the episodes
    if args.quick:
        config = dataclasses.replace(config, study=study.quick_study(config.study))
    if args.scheduler and args.jobs:
        raise study.StudyError('--jobs and --scheduler exclude each other (a cluster has as '
                               'many jobs as its workers run)')
    try:
        rows = study.run_study(config, args.out, jobs=args.jobs, scheduler=args.scheduler,
                               scheduler_timeout=args.scheduler_timeout, bag=args.bag,
                               videos=args.videos, overwrite=args.overwrite,
                               batch_size=args.batch_size or study.DEFAULT_BATCH_SIZE)
    except study.Interrupted as stopped:
        for signum in (signal.SIGINT, signal.SIGTERM):  # only the message is left to do
            signal.signal(signum, signal.SIG_IGN)
        print(f'mona-swarm study: {stopped.message()}', file=sys.stderr)
        return stopped.status
    folders = [args.out / study.EPISODES_DIR / spec.name for spec in study.design(config)]
    report = analyse(args.out, folders, table=pd.DataFrame(rows),
                     parameters_file=study.PARAMETERS_FILE, claims_files=args.claims)
    last = study.read_invocations(args.out)[-1]
    print(f'{report}: {last["episodes"]} episodes ({last["ran"]} run, {last["kept"]} kept) '
          f'in {time.perf_counter() - started:.1f} s')
    return 0


def from_episodes(args: argparse.Namespace, started: float) -> int:
    """``--from-episodes``: check and analyse existing episode folders; run nothing."""
    from mona_controller import plugins
    from swarm_metrics.bags.checks import describe
    from swarm_supervisor.analysis.claims import all_claims
    from swarm_supervisor.analysis.report import analyse
    from swarm_supervisor.outputs.guard import check_place
    from swarm_supervisor.outputs.lock import hold

    unused = [flag for flag, value in (('--config', args.config), ('--quick', args.quick),
                                       ('--jobs', args.jobs), ('--batch-size', args.batch_size),
                                       ('--scheduler', args.scheduler), ('--bag', args.bag),
                                       ('--videos', args.videos)) if value]
    if unused:
        raise study.StudyError(f'{", ".join(unused)} cannot be combined with '
                               '--from-episodes, which runs nothing')
    check_place(args.out)  # a file, a place that cannot take it, another writer
    folders = study.find_episodes(args.from_episodes)
    if not folders:
        raise study.StudyError('no episode folders (metrics.csv + episode.json) under '
                               + ', '.join(map(str, args.from_episodes)))
    plugins.ensure(study.recorded_plugins(folders))  # their metrics' entries, for claims
    all_claims(args.claims)  # a bad claims file fails now, not after the checks
    incomplete = study.incomplete_episodes(folders)
    if incomplete and not args.allow_incomplete:
        listing = '\n'.join(f'  {folder}:\n{describe(findings, "    ")}'
                            for folder, findings in incomplete.items())
        print(f'mona-swarm study: error: {len(incomplete)} of {len(folders)} episodes are '
              f'incomplete; --allow-incomplete analyses them anyway:\n{listing}',
              file=sys.stderr)
        return 1
    study.claim_analysis_folder(args.out, args.from_episodes, overwrite=args.overwrite)
    hold(args.out)  # created, and locked while the analysis is written
    report = analyse(args.out, folders, sources=[str(p) for p in args.from_episodes],
                     incomplete=incomplete, claims_files=args.claims)
    flagged = f' ({len(incomplete)} incomplete, listed in the report)' if incomplete else ''
    print(f'{report}: {len(folders)} episodes analysed{flagged} in '
          f'{time.perf_counter() - started:.1f} s')
    return 0

