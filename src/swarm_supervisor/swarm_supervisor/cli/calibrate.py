"""``mona-swarm calibrate``: search parameter ranges for the model that reproduces the paper."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from swarm_supervisor import exits
from swarm_supervisor.cli.arguments import bounded


def register(subparsers) -> None:
    """Add the ``calibrate`` subcommand."""
    parser = subparsers.add_parser(
        'calibrate', help='search parameter ranges for the model that reproduces the paper',
        description='Run the trials of a calibration design (optuna TPE, seeded): each runs '
                    'the reduced screening study with the values the search proposes and is '
                    "scored by the paper's claims and table 2's SS_speed / SS_population; the "
                    'best candidates are then rerun on the full study. Writes trials.csv, '
                    'calibration.md and best_profile.yaml (an existence search: '
                    'best_trial.yaml) into --out; an interrupted search '
                    'resumes from --out (docs/model.md, "Calibration").',
        epilog=exits.HELP + '.')
    parser.add_argument('design', type=Path, metavar='DESIGN',
                        help='calibration design (e.g. ros_ws/config/designs/calibration.yaml)')
    parser.add_argument('--out', type=Path, required=True, metavar='DIR',
                        help='the search folder (created; an existing search of the same '
                             'design is resumed)')
    parser.add_argument('--jobs', type=bounded(int, 1), metavar='J',
                        help='worker processes (default: one per CPU)')
    parser.add_argument('--scheduler', metavar='ADDRESS',
                        help='run the episodes on the workers of this Dask scheduler')
    parser.add_argument('--scheduler-timeout', type=bounded(float, 0.1), default=30.0,
                        metavar='SECONDS', help='how long to wait for the scheduler (30)')
    parser.add_argument('--keep-episodes', action='store_true',
                        help="keep every trial's episode folders (default: only its "
                             'all_metrics.csv and trial.json)')
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Search, confirm, report."""
    from swarm_supervisor.analysis.claims import paper_claims
    from swarm_supervisor.calibration import (
        best_file,
        candidates,
        confirm,
        load_design,
        load_results,
        run_search,
        write_report,
    )
    from swarm_supervisor.engine.inputs import check_inputs
    from swarm_supervisor.outputs.guard import check_place
    from swarm_supervisor.study.cluster import check_address, connect
    from swarm_supervisor.study.interrupt import StopRequest, exit_status

    started = time.perf_counter()
    design = load_design(args.design)
    if args.scheduler and args.jobs:
        print('mona-swarm calibrate: error: --jobs and --scheduler exclude each other',
              file=sys.stderr)
        return exits.USAGE
    # Every input before the first trial: the folder, the episodes' files and metrics, the
    # scheduler (each trial's study connects to it again).
    check_place(args.out)
    if args.scheduler:
        check_address(args.scheduler)
    check_inputs(design.config)
    if args.scheduler:
        connect(args.scheduler, args.scheduler_timeout).close()
    claims = paper_claims()
    options = {'jobs': args.jobs, 'scheduler': args.scheduler,
               'scheduler_timeout': args.scheduler_timeout}
    try:
        # Ctrl-C or SIGTERM stops the search wherever it is (between trials too).
        with StopRequest():
            results = run_search(design, args.out, claims, keep_episodes=args.keep_episodes,
                                 **options)
            confirmed = confirm(design, args.out, candidates(results, design.candidates),
                                claims, **options)
    except KeyboardInterrupt as error:
        told = len(load_results(args.out, design.trials))
        print(f'mona-swarm calibrate: interrupted: {told} of {design.trials} trials scored and '
              'kept; rerun the same command to resume', file=sys.stderr)
        return exit_status(error)
    report = write_report(design, args.out, results, confirmed, started)
    best = min(confirmed or results, key=lambda r: (r.score.loss, r.number))
    print(f'{report}: {len(results)} trials, {len(confirmed)} confirmed; best: trial '
          f'{best.number}, loss {best.score.loss:.3f}, {len(best.score.held)} claims hold, '
          f'ratio {best.score.ratio:.3g}; its values: {args.out / best_file(design)}')
    return exits.OK
