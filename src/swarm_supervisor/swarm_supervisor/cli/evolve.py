"""``mona-swarm evolve``: evolve a network controller with CMA-ES on the batched engine."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from swarm_supervisor import exits
from swarm_supervisor.cli.arguments import bounded


def register(subparsers) -> None:
    """Add the ``evolve`` subcommand."""
    parser = subparsers.add_parser(
        'evolve', help='evolve a network controller (CMA-ES) on the batched engine',
        description='Run the generations of an evolution design (pycma CMA-ES, seeded): each '
                    "genome, a network controller's weights, is scored by the mean cue "
                    "fraction of its episodes on the generation's training seeds (lower is "
                    'better). Writes generations.csv, fitness.png and best.npz into --out; '
                    'an interrupted run resumes from --out (docs/learned.md).',
        epilog=exits.HELP + '.')
    parser.add_argument('design', type=Path, metavar='DESIGN',
                        help='evolution design (e.g. ros_ws/config/designs/evolve.yaml)')
    parser.add_argument('--out', type=Path, required=True, metavar='DIR',
                        help='the evolution folder (created; a run of the same design is '
                             'resumed from its last generation)')
    parser.add_argument('--jobs', type=bounded(int, 1), default=None, metavar='J',
                        help='worker processes (default 1: episodes run in this process)')
    parser.add_argument('--scheduler', metavar='ADDRESS',
                        help="run each generation's batches on the workers of this Dask "
                             'distributed scheduler (e.g. tcp://10.0.0.1:8786), the same '
                             'scores as local processes (docs/learned.md)')
    parser.add_argument('--scheduler-timeout', type=bounded(float, 0.1), default=30.0,
                        metavar='SECONDS',
                        help='how long to wait for the scheduler to answer (default: 30)')
    progress = parser.add_mutually_exclusive_group()
    progress.add_argument('--progress', dest='shown', action='store_true', default=None,
                          help='show the progress bar (default: only on a terminal)')
    progress.add_argument('--no-progress', dest='shown', action='store_false')
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Evolve, then say where the results are."""
    from swarm_supervisor.engine.inputs import check_inputs
    from swarm_supervisor.evolution import EvolutionError, evolve, load_design
    from swarm_supervisor.outputs.guard import check_place
    from swarm_supervisor.study.cluster import check_address
    from swarm_supervisor.study.interrupt import StopRequest, exit_status

    if args.scheduler and args.jobs:
        raise EvolutionError('--jobs and --scheduler exclude each other (a cluster has as '
                             'many jobs as its workers run)')
    design = load_design(args.design)
    check_place(args.out)  # a file, a place that cannot take it, another writer
    if args.scheduler:  # not an address: at once (evolve() then connects)
        check_address(args.scheduler)
    check_inputs(design.base)  # its files and metrics, before the first generation
    try:
        # Ctrl-C or SIGTERM stops the evolution wherever it is (between generations too).
        with StopRequest():
            rows = evolve(design, args.out, jobs=args.jobs or 1, scheduler=args.scheduler,
                          scheduler_timeout=args.scheduler_timeout, shown=args.shown)
    except KeyboardInterrupt as error:
        print('mona-swarm evolve: interrupted: the generations finished are kept; rerun the '
              'same command to resume', file=sys.stderr)
        return exit_status(error)
    validated = [row['validation'] for row in rows if 'validation' in row]
    if validated:
        print(f'{args.out}: {len(rows)} generations, best validation of the mean '
              f'{min(validated):.4f} (mean cue fraction); weights {args.out / "best.npz"}')
    else:
        best = min(row['best'] for row in rows)
        print(f'{args.out}: {len(rows)} generations, best fitness {best:.4f} '
              f'(mean cue fraction); weights {args.out / "best.npz"}')
    return exits.OK
