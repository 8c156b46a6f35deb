"""scripts/swarm.sh as a real process in a test, and what it leaves behind."""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from harness import (
    REPO,
    domain_shm_files,
    groups_shm,
    mapped_shm,
    remove_shm_leftovers,
    shm_files,
    stop_group,
)

SWARM = REPO / 'scripts' / 'swarm.sh'
CONFIG = REPO / 'ros_ws' / 'config' / 'mona_swarm.yaml'
#: Wall-clock patience for a whole short run on a loaded 2-core machine.
RUN_TIMEOUT = 300


def group_alive(pgid: int) -> bool:
    """True while any process of group ``pgid`` exists."""
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class SwarmRun:
    """One scripts/swarm.sh run: the script's process and its output folder."""

    def __init__(self, out: Path, args: list[str], prefix: list[str] | None = None) -> None:
        """Start the script with ``args``; ``prefix`` goes before it (``ip netns exec NS``)."""
        self.out = out
        self.err_path = out.parent / f'{out.name}.stderr'
        self.seen_shm: set[str] = set()
        env = dict(os.environ, PATH=f'{Path(sys.executable).parent}{os.pathsep}'
                   f'{os.environ.get("PATH", "")}')
        with open(self.err_path, 'wb') as err:
            self.process = subprocess.Popen(
                [*(prefix or []), str(SWARM), '--out', str(out), '--timeout', str(RUN_TIMEOUT),
                 *args],
                stdout=err, stderr=subprocess.STDOUT, env=env, start_new_session=True)

    @property
    def stderr(self) -> str:
        """The script's own messages so far."""
        return self.err_path.read_text(errors='replace')

    def wait(self, timeout: float = RUN_TIMEOUT + 60) -> int:
        return self.process.wait(timeout)

    def nodes(self) -> dict[str, int]:
        """Node name -> pid (= its process group id), from <out>/processes.tsv."""
        path = self.out / 'processes.tsv'
        if not path.exists():
            return {}
        rows = [line.split('\t') for line in path.read_text().splitlines() if line]
        return {row[0]: int(row[1]) for row in rows}

    def log(self, name: str) -> str:
        path = self.out / 'logs' / f'{name}.log'
        return path.read_text(errors='replace') if path.exists() else ''

    def failed_logs(self, tail: int = 4000) -> str:
        """The log tails of the nodes the script reports FAILED (a node ended by SIGABRT has
        its Python stacks there), for a failing assertion's message."""
        names = re.findall(r'FAILED (\S+) \(pid', self.stderr)
        return ''.join(f'\n--- {name}.log (last {tail} characters) ---\n'
                       f'{self.log(name)[-tail:]}' for name in dict.fromkeys(names))

    def env(self) -> dict[str, str]:
        """The run's ROS environment (domain, middleware, profile), from <out>/ros_env.sh."""
        env = dict(os.environ)
        for line in (self.out / 'ros_env.sh').read_text().splitlines():
            if line.startswith('export '):
                key, _, value = line[len('export '):].partition('=')
                env[key] = value
        env.pop('ROS_AUTOMATIC_DISCOVERY_RANGE', None)
        return env

    def wait_for(self, condition: Callable[[], bool], what: str, timeout: float = 180) -> None:
        """Poll ``condition`` until it holds; fail the test with the logs after ``timeout``."""
        deadline = time.monotonic() + timeout
        while not condition():
            if self.process.poll() is not None:
                pytest.fail(f'swarm.sh ended ({self.process.returncode}) before {what}:\n'
                            f'{self.stderr}\n{self.log("world")[-3000:]}')
            if time.monotonic() > deadline:
                pytest.fail(f'no {what} after {timeout} s:\n{self.stderr}\n'
                            f'{self.log("world")[-3000:]}')
            time.sleep(0.25)

    def wait_running(self, after: float = 0.0) -> None:
        """Until the world runs episode 0, then ``after`` wall seconds more."""
        self.wait_for(lambda: 'episode 0 running' in self.log('world'), 'running episode')
        time.sleep(after)

    def watch_status(self) -> StatusWatch:
        """A subscriber to the run's /world/status in a process of its own (a context
        manager): ``.latest`` is the newest status document."""
        return StatusWatch(self.env(), self.out.parent / f'{self.out.name}.status')

    @property
    def domain(self) -> int:
        """The run's ROS domain id."""
        return int(self.env()['ROS_DOMAIN_ID'])

    def note_shm(self) -> set[str]:
        """Add the /dev/shm files the run's live nodes map now to :attr:`seen_shm`."""
        self.seen_shm |= groups_shm(list(self.nodes().values()))
        return self.seen_shm

    def shm_leftovers(self) -> set[str]:
        """Fast DDS files of this run still in /dev/shm and used by no process."""
        return ((domain_shm_files(self.domain) | self.seen_shm) & shm_files()) - mapped_shm()

    def stop(self) -> None:
        """Make sure nothing of this run is left: the script, every node's group, /dev/shm."""
        if self.process.poll() is None:
            self.note_shm()
            stop_group(self.process, grace=40.0)
        for pgid in self.nodes().values():
            if group_alive(pgid):
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(pgid, signal.SIGKILL)
        if (self.out / 'ros_env.sh').exists():
            remove_shm_leftovers(self.domain, self.seen_shm)


#: Prints every /world/status message, one JSON document per line.
WATCH_STATUS = """
import rclpy
from std_msgs.msg import String
from mona_controller.ros import qos
rclpy.init()
node = rclpy.create_node('status_watch')
node.create_subscription(String, qos.STATUS, lambda msg: print(msg.data, flush=True),
                         qos.STATUS_QOS)
rclpy.spin(node)
"""


class StatusWatch:
    """The world's /world/status as a run's subscriber process sees it (see
    :meth:`SwarmRun.watch_status`)."""

    def __init__(self, env: dict[str, str], log: Path) -> None:
        self.env, self.log = env, log
        self.latest: dict = {}

    def __enter__(self) -> StatusWatch:
        with open(self.log, 'wb') as log:
            self.process = subprocess.Popen([sys.executable, '-c', WATCH_STATUS],
                                            stdout=subprocess.PIPE, stderr=log, env=self.env,
                                            start_new_session=True)
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()
        return self

    def _read(self) -> None:
        for line in self.process.stdout:
            with contextlib.suppress(ValueError):
                self.latest = json.loads(line)

    def steps_left(self) -> int | None:
        """Steps the running episode has still to go by the latest status (None: not
        running)."""
        latest = self.latest
        if latest.get('state') != 'running':
            return None
        return latest['steps'] - latest['step']

    def __exit__(self, *exc: object) -> None:
        stop_group(self.process, grace=10.0)
