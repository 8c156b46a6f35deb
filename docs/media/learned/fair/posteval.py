"""One-off post-evaluation of the fair evolution, reusing the BEECLUST column of the first
post-evaluation (the same held-out seeds and parameters), checked by rerunning some seeds.

    .venv/bin/python docs/media/learned/fair/posteval.py ros_ws/config/designs/evolve_fair.yaml \
        OUT docs/media/learned/compare.csv 2     # OUT holding the run's best.npz
"""
import csv
import json
import multiprocessing
import sys
import time
from pathlib import Path

from swarm_supervisor.config import load_config
from swarm_supervisor.evolution import load_design
from swarm_supervisor.evolution.behaviour import behaviour
from swarm_supervisor.evolution.compare import figure, held_out_seeds, paired, scenario_configs
from swarm_supervisor.evolution.fitness import run_configs, run_scores


def main():
    """Post-evaluate the best genome of DESIGN in OUT (see the module docstring)."""
    design = load_design(sys.argv[1])
    out = Path(sys.argv[2])
    old = list(csv.DictReader(open(sys.argv[3])))
    checks = int(sys.argv[4])
    seeds = held_out_seeds(design)
    pool = multiprocessing.get_context('spawn').Pool(2)
    rows, summary, log = [], {}, {}
    started = time.time()
    for scenario in design.compare:
        name = Path(scenario).stem
        mine = [r for r in old if r['scenario'] == name]
        assert [int(r['seed']) for r in mine] == seeds, name
        theirs = [float(r['beeclust']) for r in mine]
        beeclust, network = scenario_configs(design, load_config(scenario), out / 'best.npz',
                                             seeds)
        rerun = run_configs(beeclust[:checks])
        assert rerun == theirs[:checks], (name, rerun, theirs[:checks])
        log[name] = f'BEECLUST rerun on {checks} seeds: equal bit for bit'
        ours = run_scores(network, design.batch, pool, 2)
        summary[name] = paired(theirs, ours)
        summary[name]['behaviour'] = {'beeclust': behaviour(beeclust[0]),
                                      'network': behaviour(network[0])}
        rows += [(name, seed, b, n) for seed, b, n in zip(seeds, theirs, ours)]
        print(name, summary[name], time.time() - started, flush=True)
    pool.close()
    pool.join()
    with (out / 'compare.csv').open('w', newline='') as handle:
        writer = csv.writer(handle)
        writer.writerow(('scenario', 'seed', 'beeclust', 'network'))
        writer.writerows(rows)
    (out / 'compare.json').write_text(json.dumps(summary, indent=2) + '\n')
    figure(out, rows, summary)
    print(json.dumps(log), time.time() - started)


if __name__ == '__main__':
    main()
