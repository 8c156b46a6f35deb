"""Stopping a study keeps every finished episode: Ctrl-C as a real signal to a real
``mona-swarm study`` process, then the same command again, and the result byte-identical to
a study that was never stopped; Ctrl-C to a study on two workers leaves no worker
behind."""

from __future__ import annotations

import json
import os
import queue
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from swarm_supervisor import outputs, study
from swarm_supervisor.cli import main
from swarm_supervisor.config import load_config, write_ros_yaml

#: 2 populations x 2 speeds x 3 seeds of 8 s; one worker and batches of 2: six batches.
DESIGN = {'populations': [3, 5], 'speeds': [0.04, 0.08], 'seeds': [1, 2, 3], 'duration': 8.0,
          'snapshot_times': [0.0, 8.0]}
EPISODES = 12
#: test_sigterm_...'s: the same cells, of 60 s each, so that episodes still run when the
#: signal comes however late a busy machine lets the test see the first one written.
SIGTERM_DESIGN = {**DESIGN, 'duration': 60.0, 'snapshot_times': [0.0, 60.0]}
#: test_a_study_killed_...'s: episodes long enough that its first batch is still running when
#: the test, having seen the worker start, kills the study.
KILL_DESIGN = {**DESIGN, 'duration': 2400.0, 'snapshot_times': [0.0, 2400.0]}
#: test_ctrl_c_...'s: 16 episodes on two workers (here, not in test_study.py, whose
#: module-scoped study would keep this slow test on that module's worker).
CTRL_C_DESIGN = {'populations': [3, 5], 'speeds': [0.04, 0.08], 'seeds': [1, 2, 3, 4],
                 'duration': 24.0, 'snapshot_times': [0.0, 6.0, 24.0]}
MESSAGE = (r'interrupted by SIGINT: (\d+) of 12 episodes kept in (\S+) \(the running batches '
           r'were cut\); rerun the same command to resume')


def command(config: Path, out: Path) -> list[str]:
    """The study as a user types it (the module, so the test needs no PATH)."""
    return [sys.executable, '-m', 'swarm_supervisor.cli', 'study', '--config', str(config),
            '--out', str(out), '--jobs', '1', '--batch-size', '2']


def session(sid: int) -> dict[int, int]:
    """The live processes of session ``sid`` (zombies, which run nothing, left out): process
    id -> its process group."""
    found = {}
    for stat in Path('/proc').glob('[0-9]*/stat'):
        try:  # after the name: state, parent, process group, session, ...
            state, _, group, member = stat.read_text().rsplit(')', 1)[1].split()[:4]
        except (OSError, ValueError):
            continue  # gone meanwhile
        if int(member) == sid and state != 'Z':
            found[int(stat.parent.name)] = int(group)
    return found


def written(out: Path) -> list[Path]:
    """The episode folders that are in place (hidden .partial folders are not)."""
    folder = out / study.EPISODES_DIR
    return sorted(p for p in folder.iterdir() if not p.name.startswith('.')) \
        if folder.is_dir() else []


def write_design(design: dict, path: Path) -> Path:
    write_ros_yaml(load_config().replace(study=design), path)
    return path


@pytest.fixture
def config(tmp_path: Path) -> Path:
    return write_design(DESIGN, tmp_path / 'design.yaml')


class StudyProcess:
    """``mona-swarm study`` in its own process group, its stderr read line by line as it
    comes (its own word on an episode written: looking at the folder instead needs imports
    that take seconds on a busy machine, by when the study may be over)."""

    def __init__(self, config: Path, out: Path) -> None:
        self.process = subprocess.Popen(command(config, out), start_new_session=True, text=True,
                                        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        self.said: list[str] = []
        self._lines: queue.Queue[str] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.process.stderr:
            self._lines.put(line)
        self._lines.put('')  # the end of its stderr

    def read_until(self, text: str) -> None:
        """Read its stderr up to a line holding ``text``; fail if it ends first."""
        while not self.said or self.said[-1] and text not in self.said[-1]:
            self.said.append(self._lines.get(timeout=180))
        assert self.said[-1], f'the study ended before saying {text!r}: {self.stderr()}'

    def signal(self, signum: int) -> None:
        """``signum`` to its process group (SIGINT: a terminal's Ctrl-C)."""
        os.killpg(self.process.pid, signum)

    def wait(self, timeout: float) -> int:
        """Its exit status, once it and its stderr ended."""
        self.process.wait(timeout=timeout)
        self._reader.join(timeout=10)
        return self.process.returncode

    def stderr(self) -> str:
        """What it said so far."""
        while not self._lines.empty():
            self.said.append(self._lines.get())
        return ''.join(self.said)

    def kill(self) -> None:
        """SIGKILL to its group unless it ended."""
        if self.process.poll() is None:
            self.signal(signal.SIGKILL)
            self.process.wait()


@pytest.mark.slow
def test_interrupted_study_keeps_every_episode_and_resumes_to_the_same_bytes(config, tmp_path):
    out = tmp_path / 'stopped'
    stopped = StudyProcess(config, out)
    try:
        stopped.read_until(f'episode 2/{EPISODES} done')
        stopped.signal(signal.SIGINT)
        status = stopped.wait(120)
    finally:
        stopped.kill()
    err = stopped.stderr()
    assert status == 130, err
    said = re.search(MESSAGE, err)
    assert said, err
    assert 'Traceback' not in err
    kept = written(out)
    assert said.group(2) == str(out)
    assert int(said.group(1)) == len(kept) and 2 <= len(kept) < EPISODES
    for folder in kept:  # every folder in place is whole; a cut one is a hidden .partial
        assert outputs.episode_complete(folder), folder
        assert (folder / outputs.SNAPSHOTS_FILE).is_file()
    last = study.read_invocations(out)[-1]
    assert last['outcome'] == 'interrupted by SIGINT'
    # An episode written as the workers were stopped may not have reported back: ran <= kept.
    assert last['complete'] == len(kept) and last['ran'] <= len(kept)
    assert not (out / study.TABLE_FILE).exists()

    resumed = subprocess.run(command(config, out), capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    runs = study.read_invocations(out)
    assert runs[-1]['outcome'] == 'finished'
    assert (runs[-1]['kept'], runs[-1]['ran']) == (len(kept), EPISODES - len(kept))

    # A study never stopped, of the same design, workers and batches, run in this process (its
    # episodes and table; the figures and the report are not compared, so not made again).
    whole = tmp_path / 'whole'
    study.run_study(load_config(config), whole, jobs=1, batch_size=2, progress=False,
                    start_method='fork')
    assert (out / study.TABLE_FILE).read_bytes() == (whole / study.TABLE_FILE).read_bytes()
    assert [p.name for p in written(out)] == [p.name for p in written(whole)]
    for folder in written(whole):
        mine = out / study.EPISODES_DIR / folder.name
        assert (mine / outputs.METRICS_FILE).read_bytes() == \
            (folder / outputs.METRICS_FILE).read_bytes(), folder.name


def test_sigterm_and_a_second_ctrl_c_stop_at_once_and_leave_no_torn_folder(tmp_path):
    out = tmp_path / 'out'
    stopped = StudyProcess(write_design(SIGTERM_DESIGN, tmp_path / 'design.yaml'), out)
    try:
        stopped.read_until(f'episode 1/{EPISODES} done')
        stopped.signal(signal.SIGTERM)
        # Once it says it stops (both pending at once, Python would take SIGINT first).
        stopped.read_until('SIGTERM received')
        stopped.signal(signal.SIGINT)  # while it stops: changes nothing
        status = stopped.wait(60)
    finally:
        stopped.kill()
    err = stopped.stderr()
    assert status == 143, err
    assert 'SIGTERM received: stopping the workers' in err
    assert 'interrupted by SIGTERM' in err and 'episodes kept in' in err
    assert 'Traceback' not in err
    for folder in written(out):
        assert outputs.episode_complete(folder), folder
    record = json.loads((out / study.TIMING_FILE).read_text())['invocations'][-1]
    assert record['outcome'] == 'interrupted by SIGTERM'
    assert record['complete'] == len(written(out))


def test_a_study_killed_outright_leaves_no_worker_writing(tmp_path):
    """SIGKILL to the study alone (kill -9, the OOM killer): its worker, in a process group of
    its own, ends with it, rather than finishing its batch and writing episodes that the same
    command, run again to resume, would be writing too."""
    out = tmp_path / 'out'
    killed = StudyProcess(write_design(KILL_DESIGN, tmp_path / 'design.yaml'), out)
    sid = killed.process.pid
    try:
        deadline = time.monotonic() + 120
        while set(session(sid).values()) <= {sid}:  # a worker leaves the study's group
            assert killed.process.poll() is None, killed.stderr()
            assert time.monotonic() < deadline, 'no worker started'
            time.sleep(0.02)
        os.kill(sid, signal.SIGKILL)
        killed.wait(60)
        deadline = time.monotonic() + 10
        while session(sid):
            assert time.monotonic() < deadline, f'workers outlived it: {session(sid)}'
            time.sleep(0.1)
    finally:
        killed.kill()
        for pid in session(sid):
            os.kill(pid, signal.SIGKILL)
    assert written(out) == []


@pytest.mark.slow
def test_ctrl_c_stops_the_workers_and_the_study_resumes(tmp_path):
    """SIGINT to the whole process group (a terminal's Ctrl-C): exit 130, no worker left,
    finished episodes kept; the next run completes the rest."""
    out = tmp_path / 'out'
    # 16 episodes of 24 s: two batches of eight, each episode written as it is done.
    config = tmp_path / 'tiny.yaml'
    write_ros_yaml(load_config().replace(study=CTRL_C_DESIGN), config)
    command = [sys.executable, '-m', 'swarm_supervisor.cli', 'study', '--out', str(out),
               '--config', str(config), '--jobs', '2']
    process = subprocess.Popen(command, start_new_session=True, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while not list(out.glob(f'{study.EPISODES_DIR}/*/{outputs.EPISODE_FILE}')):
            assert process.poll() is None, process.communicate()
            assert time.monotonic() < deadline, 'no episode finished'
            time.sleep(0.1)
        os.killpg(process.pid, signal.SIGINT)
        _, err = process.communicate(timeout=60)
        assert process.returncode == 130, err
        assert 'interrupted' in err
        deadline = time.monotonic() + 10
        # The workers are gone with the parent: no process of its session is left (they run
        # in process groups of their own, within it).
        while session(process.pid):
            assert time.monotonic() < deadline, f'workers outlived it: {session(process.pid)}'
            time.sleep(0.1)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
        for pid in session(process.pid):
            os.kill(pid, signal.SIGKILL)
    kept = study.find_episodes([out / study.EPISODES_DIR])
    assert 1 <= len(kept) < 16
    # The rest on one worker process (the stopped run's two were what had to go with it).
    assert main(['study', '--out', str(out), '--config', str(config), '--jobs', '1']) == 0
    last = study.read_invocations(out)[-1]
    assert last['kept'] == len(kept) and last['ran'] == 16 - len(kept)
