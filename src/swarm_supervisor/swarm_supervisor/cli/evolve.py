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
    parser.add_argument('--jobs', type=bounded(int, 1), default=1, metavar='J',
                        help='worker processes (default 1: episodes run in this process)')
    progress = parser.add_mutually_exclusive_group()
    progress.add_argument('--progress', dest='shown', action='store_true', default=None,
                          help='show the progress bar (default: only on a terminal)')
    progress.add_argument('--no-progress', dest='shown', action='store_false')
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Evolve, then say where the results are."""
    from swarm_supervisor.evolution import evolve, load_design

    design = load_design(args.design)
    try:
        rows = evolve(design, args.out, jobs=args.jobs, shown=args.shown)
    except KeyboardInterrupt:
        print('mona-swarm evolve: interrupted: the generations finished are kept; rerun the '
              'same command to resume', file=sys.stderr)
        return exits.INTERRUPTED
    best = min(row['best'] for row in rows)
    print(f'{args.out}: {len(rows)} generations, best fitness {best:.4f} '
          f'(mean cue fraction); weights {args.out / "best.npz"}')
    return exits.OK
