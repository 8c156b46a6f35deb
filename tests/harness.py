"""Process harness for ROS tests and benchmarks: a private domain id, process groups that are
always stopped, removal of Fast DDS shared-memory leftovers, and ports no parallel test shares.
The machinery is the one scripts/swarm.sh runs (swarm_supervisor.system.processes);
tests/conftest.py wraps it in fixtures.
"""

from __future__ import annotations

import fcntl
import os
import re
import socket
import subprocess
from pathlib import Path
from typing import IO

# Re-exported for the tests: one implementation, shared with scripts/swarm.sh.
from swarm_supervisor.system.processes import (  # noqa: F401
    LOCK_DIR,
    domain_shm_files,
    group_pids,
    groups_shm,
    mapped_shm,
    private_domain,
    remove_shm_leftovers,
    ros_environment,
    shm_files,
    start_group,
    stop_group,
    stop_groups,
)

REPO = Path(__file__).resolve().parents[1]
#: A fenced block of a Markdown page: its language and its text.
BLOCK = re.compile(r'^```(\w*)\n(.*?)^```', re.MULTILINE | re.DOTALL)


def recipes(page: str) -> tuple[dict[str, str], list[str]]:
    """docs/extending.md's recipes: its files (a block whose first line is ``# my_swarm/<name>``)
    and its command blocks (those that begin with ``cd my_swarm``), in page order."""
    files, commands = {}, []
    for _, text in BLOCK.findall(page):
        first = text.split('\n', 1)[0]
        if first.startswith('# my_swarm/'):
            files[first[2:].strip()] = text
        elif first.strip() == 'cd my_swarm':
            commands.append(text)
    return files, commands
#: Ports a test names before a process listens on them: above Linux's ephemeral range
#: (32768-60999: the kernel's picks for port 0, Fast DDS's sending sockets) and every Fast DDS
#: port of domains 1-100 (7650-32650), in a slice of PORT_SLICE per pytest-xdist worker.
PORTS = range(61000, 65536)
PORT_SLICE = 250
_held_ports: list[IO] = []


def free_port() -> int:
    """A TCP port of 127.0.0.1, free now and this test process's until it exits.

    Taken from this pytest-xdist worker's slice of :data:`PORTS` and held by a lock file
    (/tmp/mona-port-<port>.lock, flock), so neither another worker nor another pytest run on
    the machine is given it; never handed out twice in one process. For a port a test must
    name in advance (``--live-port``); a server of the test's own process binds port 0.
    """
    worker = os.environ.get('PYTEST_XDIST_WORKER', 'gw0')
    first = (int(worker[2:]) if worker[2:].isdigit() else 0) * PORT_SLICE
    for k in range(len(PORTS)):
        port = PORTS[(first + k) % len(PORTS)]
        handle = open(LOCK_DIR / f'mona-port-{port}.lock', 'w')
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        with socket.socket() as probe:
            try:
                probe.bind(('127.0.0.1', port))
            except OSError:
                handle.close()
                continue
        _held_ports.append(handle)  # kept open: the lock lasts until this process exits
        return port
    raise RuntimeError(f'no free port in {PORTS.start}..{PORTS.stop - 1}')


class Processes:
    """Processes started by one test, each in its own process group."""

    def __init__(self, env: dict[str, str], log_dir: Path) -> None:
        self.env = env
        self.log_dir = log_dir
        self.started: list[subprocess.Popen] = []
        self.seen_shm: set[str] = set()

    def spawn(self, command: list[str], name: str,
              env: dict[str, str] | None = None) -> subprocess.Popen:
        """Start ``command`` with the test's ROS environment (or ``env``), output to
        ``<name>.log``."""
        process = start_group(command, self.log_dir / f'{name}.log', env or self.env)
        process.name = name
        self.started.append(process)
        return process

    def log(self, name: str) -> str:
        """The output so far of the process started as ``name``."""
        return (self.log_dir / f'{name}.log').read_text(errors='replace')

    def note_shm(self) -> None:
        """Remember the /dev/shm files the live processes map (a killed one cannot tell)."""
        self.seen_shm |= groups_shm([process.pid for process in self.started])

    def stop_all(self) -> list[str]:
        """Stop every process group, then remove the shared-memory files they left."""
        self.note_shm()
        stop_groups(self.started, grace=10.0)
        return remove_shm_leftovers(int(self.env['ROS_DOMAIN_ID']), self.seen_shm)
