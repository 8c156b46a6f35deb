"""``mona-swarm heldout``: controllers against each other on held-out seeds (a plan)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from swarm_supervisor import exits
from swarm_supervisor.cli.arguments import bounded


def register(subparsers) -> None:
    """Add the ``heldout`` subcommand."""
    parser = subparsers.add_parser(
        'heldout', help='compare controllers on the same held-out seeds (paired tests)',
        description='Run every controller of a comparison plan on the same held-out seeds of '
                    "every scenario, then the paired Wilcoxon tests with Holm's adjustment, "
                    'effect sizes, the behaviour table and the figure of the cue left '
                    'against k (docs/learned.md). Writes scores/, summary.json, '
                    'behaviour.json, report.md and cue_vs_k.png into --out; an interrupted '
                    'comparison resumes from --out.',
        epilog=exits.HELP + '.')
    parser.add_argument('plan', type=Path, metavar='PLAN',
                        help='comparison plan (e.g. ros_ws/config/designs/learned_heldout.yaml)')
    parser.add_argument('--out', type=Path, required=True, metavar='DIR',
                        help='the comparison folder (created; a partial one is resumed)')
    parser.add_argument('--jobs', type=bounded(int, 1), default=1, metavar='J',
                        help='worker processes (default 1: episodes run in this process)')
    parser.add_argument('--only', metavar='NAMES',
                        help='score only these controllers (comma-separated) this time')
    parser.add_argument('--no-behaviour', dest='behaviour', action='store_false',
                        help='skip the behaviour table this time')
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Score what has not been scored, then write the statistics and the figure."""
    from swarm_supervisor.evolution.heldout import PlanError, load_plan, run_chunks
    from swarm_supervisor.evolution.heldout_report import report
    from swarm_supervisor.evolution.heldout_stats import behaviour_table, figure, summarise
    from swarm_supervisor.study import workers
    from swarm_supervisor.study.interrupt import Interrupted, StopRequest

    plan = load_plan(args.plan)
    only = None if args.only is None else set(args.only.split(','))
    if only is not None and not only <= set(plan.controllers):
        raise PlanError(f"--only {args.only}: the plan's controllers are "
                        + ', '.join(plan.controllers))
    pool = workers.pool(args.jobs) if args.jobs > 1 else None
    try:
        # Ctrl-C or SIGTERM stops it wherever it is (between chunks too, docs/study.md).
        with StopRequest():
            run_chunks(plan, args.out, pool, args.jobs, only)
            table = behaviour_table(plan, args.out, pool) if args.behaviour else {}
    except Interrupted as error:
        print('mona-swarm heldout: interrupted: the scores written are kept; rerun the same '
              'command to resume', file=sys.stderr)
        return error.status
    finally:
        if pool is not None:
            pool.terminate()
            pool.join()
    summary = summarise(plan, args.out)
    (args.out / 'summary.json').write_text(json.dumps(summary, indent=2) + '\n')
    (args.out / 'report.md').write_text(report(plan, summary, table))
    figure(plan, args.out)
    print(f'{args.out}: summary.json, report.md, cue_vs_k.png')
    return exits.OK
