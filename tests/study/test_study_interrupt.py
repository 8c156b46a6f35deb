"""Stopping a study keeps every finished episode: Ctrl-C as a real signal to a real
``mona-swarm study`` process, then the same command again, and the result byte-identical to
a study that was never stopped (issue 20)."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from swarm_supervisor import outputs, study
from swarm_supervisor.config import load_config, write_ros_yaml

#: 2 populations x 2 speeds x 3 seeds of 8 s; one worker and batches of 2: six batches.
DESIGN = {'populations': [3, 5], 'speeds': [0.04, 0.08], 'seeds': [1, 2, 3], 'duration': 8.0,
          'snapshot_times': [0.0, 8.0]}
EPISODES = 12
MESSAGE = r'SIGINT: (\d+) of 12 episodes kept in (\S+); rerun the same command to resume'


def command(config: Path, out: Path) -> list[str]:
    """The study as a user types it (the module, so the test needs no PATH)."""
    return [sys.executable, '-m', 'swarm_supervisor.cli', 'study', '--config', str(config),
            '--out', str(out), '--jobs', '1', '--batch-size', '2']


def written(out: Path) -> list[Path]:
    """The episode folders that are in place (hidden .partial folders are not)."""
    folder = out / study.EPISODES_DIR
    return sorted(p for p in folder.iterdir() if not p.name.startswith('.')) \
        if folder.is_dir() else []


@pytest.fixture
def config(tmp_path: Path) -> Path:
    path = tmp_path / 'design.yaml'
    write_ros_yaml(load_config().replace(study=DESIGN), path)
    return path


def stop_once_written(process: subprocess.Popen, out: Path, count: int) -> None:
    """SIGINT to the process group (a terminal's Ctrl-C) once ``count`` episodes are in place."""
    deadline = time.monotonic() + 180
    while len([p for p in written(out) if outputs.episode_complete(p)]) < count:
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline, 'no episode finished'
        time.sleep(0.05)
    os.killpg(process.pid, signal.SIGINT)


def test_interrupted_study_keeps_every_episode_and_resumes_to_the_same_bytes(config, tmp_path):
    out = tmp_path / 'stopped'
    process = subprocess.Popen(command(config, out), start_new_session=True, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        stop_once_written(process, out, 2)
        _, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    assert process.returncode == 130, err
    assert 'finishing 1 running batch (2 episodes)' in err
    said = re.search(MESSAGE, err)
    assert said, err
    assert 'Traceback' not in err
    kept = written(out)
    # The running batch was finished, not cut: what was in place, and its partner.
    assert int(said.group(1)) == len(kept) and 2 <= len(kept) < EPISODES
    for folder in kept:  # every folder in place is whole
        assert outputs.episode_complete(folder), folder
        assert (folder / outputs.SNAPSHOTS_FILE).is_file()
    assert not list((out / study.EPISODES_DIR).glob('.*'))  # nothing half-written
    last = study.read_invocations(out)[-1]
    assert last['outcome'] == 'interrupted by SIGINT'
    assert (last['ran'], last['complete']) == (len(kept), len(kept))
    assert not (out / study.TABLE_FILE).exists()

    resumed = subprocess.run(command(config, out), capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    runs = study.read_invocations(out)
    assert runs[-1]['outcome'] == 'finished'
    assert (runs[-1]['kept'], runs[-1]['ran']) == (len(kept), EPISODES - len(kept))

    whole = tmp_path / 'whole'
    once = subprocess.run(command(config, whole), capture_output=True, text=True, timeout=300)
    assert once.returncode == 0, once.stderr
    assert (out / study.TABLE_FILE).read_bytes() == (whole / study.TABLE_FILE).read_bytes()
    assert [p.name for p in written(out)] == [p.name for p in written(whole)]
    for folder in written(whole):
        mine = out / study.EPISODES_DIR / folder.name
        assert (mine / outputs.METRICS_FILE).read_bytes() == \
            (folder / outputs.METRICS_FILE).read_bytes(), folder.name


def test_second_ctrl_c_or_sigterm_stops_at_once_and_leaves_no_torn_folder(config, tmp_path):
    out = tmp_path / 'out'
    process = subprocess.Popen(command(config, out), start_new_session=True, text=True,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        stop_once_written(process, out, 2)
        time.sleep(0.2)
        os.killpg(process.pid, signal.SIGTERM)  # while it finishes the running batch
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    # The first signal names the status: SIGINT, then SIGTERM cutting the batch.
    assert process.returncode == 130, err
    assert 'episodes kept in' in err and 'Traceback' not in err
    for folder in written(out):
        assert outputs.episode_complete(folder), folder
    record = json.loads((out / study.TIMING_FILE).read_text())['invocations'][-1]
    assert record['complete'] == len(written(out))
