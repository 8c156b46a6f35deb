"""Process harness for ROS tests and benchmarks: a private domain id, process groups that are
always stopped, and removal of Fast DDS shared-memory leftovers. tests/conftest.py wraps these
in fixtures; bench/bench_lockstep.py uses them directly.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import re
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PROFILE = REPO / 'ros_ws' / 'config' / 'fastdds_localhost.xml'
SHM = Path('/dev/shm')
SHM_PREFIXES = ('fastrtps_', 'fast_datasharing', 'sem.fastrtps_')
#: Domains 1..100 keep every Fast DDS port below Linux's ephemeral range (32768).
DOMAINS = range(1, 101)
LOCK_DIR = Path('/tmp')


def domain_ports_free(domain: int) -> bool:
    """True if no process holds the domain's multicast port or its first participant ports."""
    base = 7400 + 250 * domain
    for port in (base, base + 10, base + 12):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind(('0.0.0.0', port))
            except OSError:
                return False
    return True


@contextlib.contextmanager
def private_domain() -> Iterator[int]:
    """Hold a free ROS domain id for the duration of the block.

    The lock file (/tmp/mona-ros-domain-<id>.lock, flock) is the one scripts/swarm.sh takes.
    """
    start = os.getpid() % len(DOMAINS)
    for k in range(len(DOMAINS)):
        domain = DOMAINS[(start + k) % len(DOMAINS)]
        handle = open(LOCK_DIR / f'mona-ros-domain-{domain}.lock', 'w')
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        if not domain_ports_free(domain):
            handle.close()
            continue
        try:
            yield domain
        finally:
            handle.close()
        return
    raise RuntimeError('no free ROS domain id in 1..100')


def shm_files() -> set[str]:
    """The Fast DDS shared-memory files in /dev/shm now."""
    return {p.name for p in SHM.glob('*') if p.name.startswith(SHM_PREFIXES)}


def domain_shm_files(domain: int) -> set[str]:
    """The Fast DDS port files of ``domain`` (fastrtps_port<P>..., P in the domain's block).

    Port files name their port, so they can be told apart from other runs' files; segment
    files (fastrtps_<hex>) cannot, and only :func:`mapped_shm` attributes those.
    """
    low = 7400 + 250 * domain
    found = set()
    for name in shm_files():
        digits = re.search(r'fastrtps_port(\d+)', name)
        if digits and low <= int(digits.group(1)) < low + 250:
            found.add(name)
    return found


def group_pids(pgid: int) -> list[int]:
    """The live processes of process group ``pgid``."""
    pids = []
    for stat in Path('/proc').glob('[0-9]*/stat'):
        with contextlib.suppress(OSError, ValueError, IndexError):
            if int(stat.read_text().rsplit(')', 1)[1].split()[2]) == pgid:
                pids.append(int(stat.parent.name))
    return pids


def _shm_names(text: str) -> set[str]:
    """The Fast DDS /dev/shm file names in ``text``."""
    return {word[len('/dev/shm/'):] for word in text.split()
            if word.startswith('/dev/shm/') and word[len('/dev/shm/'):].startswith(SHM_PREFIXES)}


def mapped_shm(pids: list[int] | None = None) -> set[str]:
    """The Fast DDS /dev/shm files that the given processes (default: all) map or hold open."""
    used: set[str] = set()
    procs = [Path('/proc') / str(pid) for pid in pids] if pids is not None else \
        list(Path('/proc').glob('[0-9]*'))
    for proc in procs:
        with contextlib.suppress(OSError):
            used |= _shm_names((proc / 'maps').read_text())
        with contextlib.suppress(OSError):
            for fd in (proc / 'fd').iterdir():
                with contextlib.suppress(OSError):
                    used |= _shm_names(os.readlink(fd))
    return used


def remove_shm_leftovers(domain: int, seen: set[str] = frozenset()) -> list[str]:
    """Remove the Fast DDS files of a finished run that no live process uses: the port files
    of ``domain`` and the files its processes were ``seen`` mapping. Returns their names."""
    leftovers = sorted(((domain_shm_files(domain) | seen) & shm_files()) - mapped_shm())
    for name in leftovers:
        with contextlib.suppress(FileNotFoundError):
            (SHM / name).unlink()
    return leftovers


def ros_environment(domain: int) -> dict[str, str]:
    """The environment of a node process in ``domain`` (what scripts/swarm.sh sets too)."""
    env = dict(os.environ)
    env.pop('ROS_AUTOMATIC_DISCOVERY_RANGE', None)
    env.pop('ROS_LOCALHOST_ONLY', None)
    env.update(ROS_DOMAIN_ID=str(domain), RMW_IMPLEMENTATION='rmw_fastrtps_cpp',
               FASTRTPS_DEFAULT_PROFILES_FILE=str(PROFILE), PYTHONUNBUFFERED='1',
               PATH=f'{Path(sys.executable).parent}{os.pathsep}{env.get("PATH", "")}')
    return env


def stop_group(process: subprocess.Popen, grace: float = 10.0) -> int:
    """Stop a process and its group: SIGINT, then SIGTERM, then SIGKILL; return its status."""
    for sig, wait in ((signal.SIGINT, grace), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
        if process.poll() is not None:
            break
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, sig)
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.wait(wait)
    # The leader may be gone while others in its group live on.
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGKILL)
    return process.wait()


class Processes:
    """Processes started by one test, each in its own process group."""

    def __init__(self, env: dict[str, str], log_dir: Path) -> None:
        self.env = env
        self.log_dir = log_dir
        self.started: list[subprocess.Popen] = []
        self.seen_shm: set[str] = set()

    def spawn(self, command: list[str], name: str, **kwargs) -> subprocess.Popen:
        """Start ``command`` with the test's ROS environment, output to ``<name>.log``."""
        log = open(self.log_dir / f'{name}.log', 'wb')
        kwargs.setdefault('env', self.env)
        process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT,
                                   start_new_session=True, **kwargs)
        log.close()
        process.name = name
        self.started.append(process)
        return process

    def log(self, name: str) -> str:
        """The output so far of the process started as ``name``."""
        return (self.log_dir / f'{name}.log').read_text(errors='replace')

    def note_shm(self) -> None:
        """Remember the /dev/shm files the live processes map (a killed one cannot tell)."""
        for process in self.started:
            self.seen_shm |= mapped_shm(group_pids(process.pid))

    def stop_all(self) -> list[str]:
        """Stop every process group, then remove the shared-memory files they left."""
        self.note_shm()
        for process in self.started:
            stop_group(process)
        domain = int(self.env['ROS_DOMAIN_ID'])
        return remove_shm_leftovers(domain, self.seen_shm)


@contextlib.contextmanager
def busy_cores(count: int | None = None, limit: float = 900.0) -> Iterator[None]:
    """Keep ``count`` cores (default: all) busy with spinning processes during the block.

    The loops end with the block, and by themselves after ``limit`` seconds whatever happens
    to the test, so a crashed run cannot leave a machine loaded.
    """
    spin = f'import time\nend = time.monotonic() + {limit}\nwhile time.monotonic() < end: pass'
    loops = [subprocess.Popen([sys.executable, '-c', spin])
             for _ in range(count or os.cpu_count() or 1)]
    try:
        yield
    finally:
        for loop in loops:
            loop.kill()
            loop.wait()
