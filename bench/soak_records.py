"""Soak the node system's records: run scripts/swarm.sh again and again and check every bag.

For each run: the script's exit status, and for each episode whether its bag passes every
completeness check (swarm_metrics.bags.completeness) and whether its recomputed metrics equal the
embedded runner's for the same seed, exactly. Not a test: it prints a table to quote.

    .venv/bin/python bench/soak_records.py --runs 10 --population 50 --episodes 3 --duration 400
    .venv/bin/python bench/soak_records.py --runs 10 --population 5 --busy 2 ...
"""

from __future__ import annotations

import argparse
import contextlib
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from swarm_metrics.bags.completeness import check_bag
from swarm_metrics.bags.reader import read_episode_bag
from swarm_metrics.bags.scan import BagError
from swarm_supervisor.config import load_config
from swarm_supervisor.engine.runner import run_episode
from swarm_supervisor.system.processes import busy_cores

REPO = Path(__file__).resolve().parents[1]
CONFIG = REPO / 'ros_ws' / 'config' / 'mona_swarm.yaml'


def check_episode(bag: Path, seed: int, population: int, duration: float) -> tuple[bool, bool]:
    """(the bag passes every check, its metrics equal the embedded runner's)."""
    try:
        result, findings = check_bag(read_episode_bag(bag))
    except (BagError, OSError) as error:
        print(f'    {bag}: {error}')
        return False, False
    for finding in findings:
        print(f'    {bag}: {finding}')
    config = load_config(CONFIG).replace(
        episode={'population': population, 'duration': duration, 'seed': seed})
    equal = result is not None and result.rows == run_episode(config).metrics
    return not findings, equal


def bag_of(folder: Path, episode: int) -> Path:
    """Episode k's bag: as the metrics node reported it in run.json, else where it goes."""
    try:
        record = json.loads((folder / 'run.json').read_text())['episodes'][episode]
        return Path(record['records']['metrics']['path'])
    except (OSError, ValueError, KeyError, IndexError):
        return folder / f'episode_{episode}' / 'bag'


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--runs', type=int, default=10)
    parser.add_argument('--population', type=int, default=5)
    parser.add_argument('--episodes', type=int, default=3)
    parser.add_argument('--duration', type=float, default=400.0)
    parser.add_argument('--seed', type=int, default=100, help='first run seed (+ 10 per run)')
    parser.add_argument('--busy', type=int, default=0, help='busy-loop processes meanwhile')
    parser.add_argument('--out', type=Path, help='keep the runs here (default: a temp dir)')
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix='soak-'))
    exits, bags, complete, equal = [], 0, 0, 0
    print(f'{args.runs} runs of N = {args.population}, {args.episodes} x {args.duration:g} s, '
          f'{args.busy} busy loops; output {out}')
    print('run  exit  wall_s  episodes complete  equal to embedded')
    with busy_cores(args.busy) if args.busy else contextlib.nullcontext():
        for run in range(args.runs):
            seed = args.seed + 10 * run
            folder = out / f'run_{run}'
            if folder.exists():
                parser.error(f'{folder} exists: give a new --out (its bags would be checked)')
            started = time.monotonic()
            status = subprocess.run(
                [str(REPO / 'scripts' / 'swarm.sh'), '--population', str(args.population),
                 '--episodes', str(args.episodes), '--duration', str(args.duration),
                 '--seed', str(seed), '--out', str(folder)],
                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True).returncode
            wall = time.monotonic() - started
            results = [check_episode(bag_of(folder, k), seed + k, args.population,
                                     args.duration)
                       for k in range(args.episodes)]
            exits.append(status)
            bags += len(results)
            complete += sum(c for c, _ in results)
            equal += sum(e for _, e in results)
            print(f'{run:3d}  {status:4d}  {wall:6.0f}  {sum(c for c, _ in results):8d}/'
                  f'{len(results)}  {sum(e for _, e in results):8d}/{len(results)}',
                  flush=True)
    print(f'exit 0: {exits.count(0)} of {len(exits)}; bags complete: {complete} of {bags}; '
          f'equal to embedded: {equal} of {bags}')
    return 0 if exits.count(0) == len(exits) and complete == equal == bags else 1


if __name__ == '__main__':
    sys.exit(main())
