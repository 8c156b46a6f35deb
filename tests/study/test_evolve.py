"""``mona-swarm evolve``: the same seed and design give the same run, interrupted (SIGINT)
and resumed or not; a bad design is refused naming the key; the fitness does not depend on
how the episodes are batched."""

import dataclasses
import json
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import yaml

from swarm_supervisor.evolution import load_design
from swarm_supervisor.evolution.fitness import evaluate
from swarm_supervisor.evolution.run import COLUMNS, read_csv

TINY = {'seed': 3, 'genomes': 4, 'generations': 3, 'episodes': 1, 'robots': 5,
        'duration': 60.0, 'hidden': 3}


def write_design(path, **changes):
    path.write_text(yaml.safe_dump({'evolve': {**TINY, **changes}}))
    return path


def command(design, out):
    return [sys.executable, '-m', 'swarm_supervisor.cli', 'evolve', str(design), '--out',
            str(out), '--no-progress']


def without_wall_time(out):
    return [{c: row[c] for c in COLUMNS if c != 'wall_s'}
            for row in read_csv(out / 'generations.csv')]


def in_process(design, out, *extra):
    """The command in this process (its modules imported once, not per command); the exit
    status and what it wrote to stderr."""
    import contextlib
    import io

    from swarm_supervisor.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        status = main(command(design, out)[3:] + list(extra))
    return status, err.getvalue()


def test_an_interrupted_and_resumed_evolution_equals_an_uninterrupted_one(tmp_path):
    design = write_design(tmp_path / 'tiny.yaml')
    whole, parts = tmp_path / 'whole', tmp_path / 'parts'
    # The uninterrupted run in this process: what is compared is its files, not its process.
    status, err = in_process(design, whole)
    assert status == 0, err
    process = subprocess.Popen(command(design, parts), stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not (parts / 'checkpoint.pkl').exists() and time.monotonic() < deadline:
        time.sleep(0.005)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert 'interrupted' in err
    done = len(read_csv(parts / 'generations.csv'))
    assert 1 <= done < TINY['generations']
    resumed = subprocess.run(command(design, parts), capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    assert without_wall_time(parts) == without_wall_time(whole)
    assert len(without_wall_time(whole)) == TINY['generations']
    assert (parts / 'best.npz').read_bytes() == (whole / 'best.npz').read_bytes()
    assert (whole / 'fitness.png').stat().st_size > 0
    # Another design is refused on a folder that holds this one's run.
    other = write_design(tmp_path / 'other.yaml', seed=4)
    status, err = in_process(other, parts)
    assert status == 2 and 'another design' in err


@pytest.mark.parametrize(('changes', 'message'), [
    ({'populaton': 3}, 'unknown key evolve.populaton'),
    ({'genomes': 1}, r'evolve.genomes = 1 is out of range'),
    ({'hidden': 0}, r'evolve.hidden = 0 is out of range'),
    ({'duration': 'long'}, r"evolve.duration = 'long': expected a number"),
    ({'config': 'missing.yaml'}, r'evolve.config: cannot read'),
    ({'max_speed': 2.0}, r'evolve.max_speed = 2.0 is out of range'),
    ({'clean_stops': 'yes'}, r"evolve.clean_stops = 'yes': expected true or false"),
    ({'strategy': 'nes'}, r"evolve.strategy = 'nes': one of cma_es, openai_es"),
    ({'strategy': 'openai_es', 'genomes': 5}, r'evolve.genomes = 5: openai_es needs an even'),
])
def test_a_bad_design_is_refused_with_exit_2_naming_the_key(tmp_path, changes, message):
    design = write_design(tmp_path / 'bad.yaml', **changes)
    result = subprocess.run(command(design, tmp_path / 'out'), capture_output=True,
                            text=True)
    assert result.returncode == 2
    assert re.search(message, result.stderr), result.stderr
    assert not (tmp_path / 'out').exists()


def test_the_fitness_does_not_depend_on_the_batches(tmp_path):
    design = load_design(write_design(tmp_path / 'tiny.yaml', episodes=2, duration=20.0))
    genomes = np.random.default_rng(0).normal(size=(3, design.genome_size))
    one = evaluate(dataclasses.replace(design, batch=1), genomes, 0, tmp_path / 'a', None, 1)
    six = evaluate(dataclasses.replace(design, batch=6), genomes, 0, tmp_path / 'b', None, 1)
    assert one == six and len(set(one)) == 3


def test_the_post_evaluation_pairs_the_best_genome_with_beeclust_on_held_out_seeds(tmp_path):
    from swarm_supervisor.evolution import evolve
    from swarm_supervisor.evolution.compare import held_out_seeds
    from swarm_supervisor.evolution.fitness import training_seeds

    design = load_design(write_design(tmp_path / 'tiny.yaml', generations=1, duration=20.0,
                                      held_out=6))
    seeds = held_out_seeds(design)
    assert len(set(seeds)) == 6 and not set(seeds) & set(training_seeds(design, 0))
    evolve(design, tmp_path / 'out', shown=False)
    summary = json.loads((tmp_path / 'out' / 'compare.json').read_text())
    assert list(summary) == ['default'] and summary['default']['episodes'] == 6
    assert set(summary['default']['behaviour']) == {'beeclust', 'network'}
    rows = read_csv(tmp_path / 'out' / 'compare.csv')
    assert [int(row['seed']) for row in rows] == seeds
    assert (tmp_path / 'out' / 'compare.png').stat().st_size > 0


def test_an_evolution_extended_by_raising_generations_equals_one_run_of_them(tmp_path):
    whole, parts = tmp_path / 'whole', tmp_path / 'parts'
    full = write_design(tmp_path / 'full.yaml')
    short = write_design(tmp_path / 'short.yaml', generations=TINY['generations'] - 1)
    assert in_process(full, whole)[0] == 0
    assert in_process(short, parts)[0] == 0
    assert len(without_wall_time(parts)) == TINY['generations'] - 1
    assert in_process(full, parts)[0] == 0
    assert without_wall_time(parts) == without_wall_time(whole)
    assert (parts / 'best.npz').read_bytes() == (whole / 'best.npz').read_bytes()
    assert yaml.safe_load((parts / 'design.yaml').read_text())['evolve']['generations'] == \
        TINY['generations']
    # Fewer generations than the folder holds is refused, naming the key.
    fewer = write_design(tmp_path / 'fewer.yaml', generations=1)
    status, err = in_process(fewer, parts)
    assert status == 2, err
    assert 'more than evolve.generations = 1' in err


@pytest.fixture
def dask_scheduler():
    """A real dask.distributed cluster on loopback: a scheduler and two one-thread worker
    processes (they import this project as a remote worker would). One test uses it: made
    for that test, so the module's other tests are not tied to its worker (tests/suite.py
    keeps a module with a module-scoped fixture on one worker)."""
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host='127.0.0.1',
                      scheduler_port=0, dashboard_address=None) as cluster:
        yield cluster.scheduler_address


@pytest.mark.slow
def test_an_evolution_on_a_dask_scheduler_equals_one_in_this_process(tmp_path,
                                                                     dask_scheduler):
    design = write_design(tmp_path / 'tiny.yaml', held_out=3, max_speed=0.08,
                          clean_stops=True, duration=20.0)
    local, cluster = tmp_path / 'local', tmp_path / 'cluster'
    status, err = in_process(design, local, '--jobs', '1')
    assert status == 0, err
    status, err = in_process(design, cluster, '--scheduler', dask_scheduler)
    assert status == 0, err
    assert without_wall_time(cluster) == without_wall_time(local)
    assert len(without_wall_time(local)) == TINY['generations']
    assert (cluster / 'best.npz').read_bytes() == (local / 'best.npz').read_bytes()
    assert (cluster / 'compare.csv').read_bytes() == (local / 'compare.csv').read_bytes()


def test_a_batch_carries_its_weights_so_a_worker_needs_no_shared_files(tmp_path):
    from swarm_supervisor.evolution.cluster import portable, run_portable
    from swarm_supervisor.evolution.fitness import generation_configs, run_configs

    design = load_design(write_design(tmp_path / 'tiny.yaml', episodes=2, duration=10.0))
    genomes = np.random.default_rng(1).normal(size=(2, design.genome_size))
    configs = generation_configs(design, genomes, 0, tmp_path / 'genomes')
    here = run_configs(configs)
    task = portable(configs)
    assert len(task[1]) == 2  # one file per genome, not per episode
    for path in (tmp_path / 'genomes').iterdir():
        path.unlink()  # the worker's filesystem holds none of them
    assert run_portable(run_configs, task) == here
    assert len(set(here)) == 4  # two genomes on two seeds


def test_an_unreachable_scheduler_or_jobs_with_it_exits_2_writing_nothing(tmp_path):
    design = write_design(tmp_path / 'tiny.yaml')
    out = tmp_path / 'out'
    nobody = subprocess.run([*command(design, out), '--scheduler', 'tcp://127.0.0.1:9',
                             '--scheduler-timeout', '1'], capture_output=True, text=True,
                            timeout=120)
    assert nobody.returncode == 2, nobody.stderr
    assert 'cannot reach the Dask scheduler at tcp://127.0.0.1:9' in nobody.stderr
    both = subprocess.run([*command(design, out), '--scheduler', 'tcp://127.0.0.1:9',
                           '--jobs', '2'], capture_output=True, text=True, timeout=120)
    assert both.returncode == 2 and 'exclude each other' in both.stderr
    assert not out.exists()


def test_the_behaviour_measures_tell_a_fast_cleaner_from_a_fair_one_and_beeclust():
    from pathlib import Path

    from swarm_supervisor.config import load_config
    from swarm_supervisor.evolution.behaviour import behaviour

    root = Path(__file__).resolve().parents[2]
    net = load_config(root / 'ros_ws' / 'config' / 'controllers' / 'evolved.yaml').replace(
        episode={'population': 30, 'duration': 60.0, 'seed': 11})
    free = behaviour(net)  # the shipped evolved controller: cleans while driving fast
    assert free['cleaner_on'] > 0.9 and free['forward_speed'] > 0.08
    assert free['standing'] == 0.0
    fair = behaviour(net.replace(controller={'network': {'max_speed': 0.08,
                                                         'clean_stops': True}}))
    assert fair['standing'] >= fair['cleaner_on'] > 0.9  # a cleaning robot stands
    assert fair['forward_speed'] < 0.01
    beeclust = behaviour(net.replace(controller={'kind': 'beeclust'}))
    assert 0.0 < beeclust['cleaner_on'] < 0.9 and beeclust['forward_speed'] <= 0.08
    assert beeclust['cleaning_beside_robot'] > 0.5  # it waits after meeting a robot
    assert beeclust['moving_speed'] > beeclust['forward_speed']


def test_openai_es_descends_a_quadratic_with_the_same_bits_for_the_same_seed():
    from swarm_supervisor.evolution.strategies import OpenAIES, centred_ranks

    assert centred_ranks([3.0, 1.0, 2.0]).tolist() == [0.5, -0.5, 0.0]
    target = np.linspace(-1.0, 1.0, 10)

    def run(seed):
        strategy = OpenAIES(10, 0.1, 8, seed, learning_rate=0.05)
        for _ in range(150):
            genomes = strategy.ask()
            strategy.tell(genomes, [float(np.sum((g - target) ** 2)) for g in genomes])
        return strategy.mean

    mean = run(1)
    assert np.sum((mean - target) ** 2) < 0.05 * np.sum(target ** 2)  # from 100 % at zero
    assert run(1).tobytes() == mean.tobytes()
    assert run(2).tobytes() != mean.tobytes()
    with pytest.raises(ValueError, match='the genomes of the last ask'):
        OpenAIES(10, 0.1, 8, 1, 0.05).tell([np.zeros(10)] * 8, [0.0] * 8)


def test_an_interrupted_openai_es_evolution_resumes_to_the_same_run(tmp_path):
    from swarm_supervisor.evolution import evolve

    design = load_design(write_design(tmp_path / 'tiny.yaml', strategy='openai_es',
                                      learning_rate=0.05, duration=30.0))
    whole = evolve(design, tmp_path / 'whole', shown=False)

    def stop_after_the_first(generation):
        if generation == 0:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        evolve(design, tmp_path / 'parts', shown=False, on_checkpoint=stop_after_the_first)
    assert len(read_csv(tmp_path / 'parts' / 'generations.csv')) == 1
    resumed = evolve(design, tmp_path / 'parts', shown=False)
    drop = [{k: v for k, v in row.items() if k != 'wall_s'} for row in whole]
    assert [{k: v for k, v in row.items() if k != 'wall_s'} for row in resumed] == drop
    assert (tmp_path / 'parts' / 'best.npz').read_bytes() == \
        (tmp_path / 'whole' / 'best.npz').read_bytes()
    assert len({row['mean'] for row in whole}) == TINY['generations']  # the mean moves
    assert {row['sigma'] for row in whole} == {design.sigma}  # openai_es keeps sigma


def test_validation_chooses_the_mean_stops_when_it_stops_improving_and_resumes(tmp_path):
    from swarm_supervisor.evolution import evolve
    from swarm_supervisor.evolution.compare import held_out_seeds
    from swarm_supervisor.evolution.fitness import training_seeds
    from swarm_supervisor.evolution.genomes import start_genome
    from swarm_supervisor.evolution.validation import validation_seeds

    design = load_design(write_design(
        tmp_path / 'valid.yaml', kind='stand_net', start='drives', genomes=0, diagonal=True,
        generations=30, duration=5.0, validation=2, validate_every=1, patience=2,
        held_out=3, max_speed=0.08))
    assert design.population == 4 + int(3 * np.log(design.genome_size))  # pycma's default
    valid = validation_seeds(design)
    assert len(set(valid)) == 2 and all(2**31 <= seed < 2**32 for seed in valid)
    assert not set(valid) & ({s for g in range(30) for s in training_seeds(design, g)}
                             | set(held_out_seeds(design)))
    whole = evolve(dataclasses.replace(design, held_out=0), tmp_path / 'whole', shown=False)
    scores = [row['validation'] for row in whole]
    best = int(np.argmin(scores))
    # It stopped once two validations in a row did not beat the best, well before 30.
    assert len(whole) == best + 3 < 30 and min(scores[-2:]) >= scores[best]
    chosen = json.loads((tmp_path / 'whole' / 'chosen.json').read_text())
    assert chosen['generation'] == best and chosen['validation'] == scores[best]
    assert chosen['validation_seeds'] == valid
    assert whole[0]['best'] != whole[1]['best']
    assert len({row['sigma'] for row in whole}) == len(whole)  # pycma adapts it

    def stop_after_the_first(generation):
        if generation == 0:
            raise KeyboardInterrupt

    parts = dataclasses.replace(design, held_out=0)
    with pytest.raises(KeyboardInterrupt):
        evolve(parts, tmp_path / 'parts', shown=False, on_checkpoint=stop_after_the_first)
    resumed = evolve(parts, tmp_path / 'parts', shown=False)
    drop = [{k: v for k, v in row.items() if k != 'wall_s'} for row in whole]
    assert [{k: v for k, v in row.items() if k != 'wall_s'} for row in resumed] == drop
    for name in ('best.npz', 'chosen.json', 'generations.csv'):
        if name == 'generations.csv':
            assert without_wall_time(tmp_path / 'parts') == without_wall_time(
                tmp_path / 'whole')
        else:
            assert (tmp_path / 'parts' / name).read_bytes() == \
                (tmp_path / 'whole' / name).read_bytes()
    # The search started from a net that drives: both wheel biases 1, the stand's -1.
    assert start_genome(design)[-3:].tolist() == [1.0, 1.0, -1.0]
