"""The study on a real Dask cluster on loopback: a `dask scheduler` and two `dask worker`
processes started and stopped here. Same tables as a local run, bags included; a worker
killed mid-study costs only its episode, which another worker runs again."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from swarm_supervisor import outputs, study
from swarm_supervisor.config import load_config, write_ros_yaml

DASK = Path(sys.executable).parent / 'dask'
MONA_SWARM = Path(sys.executable).parent / 'mona-swarm'
DESIGN = {'populations': [4, 8], 'speeds': [0.08], 'seeds': [1, 2, 3], 'duration': 60.0,
          'snapshot_times': [0.0, 60.0]}
EPISODES = 6

pytestmark = pytest.mark.slow


def start(args: list[str], log: Path) -> subprocess.Popen:
    return subprocess.Popen(args, stdout=log.open('w'), stderr=subprocess.STDOUT,
                            start_new_session=True)


def stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGKILL)
    process.wait(timeout=30)


@pytest.fixture
def cluster(tmp_path: Path) -> Iterator[tuple[str, list[subprocess.Popen]]]:
    """(scheduler address, the two worker processes)."""
    scheduler_file = tmp_path / 'scheduler.json'
    processes = [start([str(DASK), 'scheduler', '--host', '127.0.0.1', '--port', '0',
                        '--no-dashboard', '--scheduler-file', str(scheduler_file)],
                       tmp_path / 'scheduler.log')]
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.exists():
            assert time.monotonic() < deadline, (tmp_path / 'scheduler.log').read_text()
            time.sleep(0.2)
        time.sleep(0.5)  # the file is written before it is complete on some versions
        address = json.loads(scheduler_file.read_text())['address']
        workers = [start([str(DASK), 'worker', address, '--nthreads', '1', '--no-nanny',
                          '--no-dashboard', '--name', f'w{k}'], tmp_path / f'worker{k}.log')
                   for k in range(2)]
        processes += workers
        yield address, workers
    finally:
        for process in processes:
            stop(process)


def run_study(out: Path, config: Path, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(MONA_SWARM), 'study', '--out', str(out), '--config', str(config),
                           *extra], capture_output=True, text=True, timeout=600)


def test_cluster_study_equals_local_and_survives_a_killed_worker(cluster, tmp_path):
    address, workers = cluster
    config = tmp_path / 'design.yaml'
    write_ros_yaml(load_config().replace(study=DESIGN), config)
    # The local study in this process: its episodes and table are what is compared.
    study.run_study(load_config(config), tmp_path / 'local', jobs=2, progress=False,
                    start_method='fork')

    out = tmp_path / 'cluster'
    # One episode a task: the six are spread over both workers (one batch of six would run
    # on one worker, and all its episodes would be written together).
    running = subprocess.Popen([str(MONA_SWARM), 'study', '--out', str(out), '--config',
                                str(config), '--scheduler', address, '--bag',
                                '--batch-size', '1'],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # Kill one worker as soon as the first episode is written: the other episodes are then
    # queued or running, one of them on the worker that dies.
    deadline = time.monotonic() + 300
    while not (done := [p for p in (out / study.EPISODES_DIR).glob('*')
                        if outputs.episode_complete(p)]):
        assert running.poll() is None, running.communicate()
        assert time.monotonic() < deadline, 'no episode finished on the cluster'
        time.sleep(0.1)
    os.killpg(workers[0].pid, signal.SIGKILL)
    assert len(done) < EPISODES and running.poll() is None  # killed mid-study
    stdout, stderr = running.communicate(timeout=600)
    assert running.returncode == 0, stderr

    assert (out / study.TABLE_FILE).read_bytes() == \
        (tmp_path / 'local' / study.TABLE_FILE).read_bytes()
    for folder in sorted((out / study.EPISODES_DIR).iterdir()):
        twin = tmp_path / 'local' / study.EPISODES_DIR / folder.name
        for name in (outputs.METRICS_FILE, outputs.SNAPSHOTS_FILE):
            assert (folder / name).read_bytes() == (twin / name).read_bytes(), folder
        # The bag (a folder) came back from the worker too.
        assert (folder / study.BAG_DIR / 'metadata.yaml').exists(), folder
        assert list((folder / study.BAG_DIR).glob('*.mcap')), folder
    record = study.read_invocations(out)[-1]
    assert record['scheduler'] == address and record['ran'] == EPISODES

    # Resumable: nothing left to run (in this process: the finished study is not analysed
    # again).
    study.run_study(load_config(config), out, scheduler=address, progress=False)
    assert study.read_invocations(out)[-1]['ran'] == 0


def test_unreachable_scheduler_is_a_clear_error(tmp_path):
    config = tmp_path / 'design.yaml'
    write_ros_yaml(load_config().replace(study=DESIGN), config)
    result = run_study(tmp_path / 'out', config, '--scheduler', 'tcp://127.0.0.1:9',
                       '--scheduler-timeout', '2')
    assert result.returncode == 2
    assert 'cannot reach the Dask scheduler at tcp://127.0.0.1:9' in result.stderr
