"""Process harness for ROS tests and benchmarks: a private domain id, process groups that are
always stopped, and removal of Fast DDS shared-memory leftovers. The machinery is the one
scripts/swarm.sh runs (swarm_supervisor.system.processes); tests/conftest.py wraps it in fixtures.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

# Re-exported for the tests: one implementation, shared with scripts/swarm.sh.
from swarm_supervisor.system.processes import (  # noqa: F401
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
