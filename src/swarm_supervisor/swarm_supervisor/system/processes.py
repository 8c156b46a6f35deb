"""Node processes on one machine: a private ROS domain, one process group per node, the signal
ladder that stops them, the Fast DDS files they leave in /dev/shm, and the Fast DDS profile of
a run across hosts.

Used by ``mona-swarm launch`` (:mod:`swarm_supervisor.system.launcher`), the tests' harness
and the benchmarks. No ROS imports: the nodes are executables started as subprocesses.
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import IO

from swarm_supervisor.config import shipped
from swarm_supervisor.system import child

#: The Fast DDS profile of every run: loopback only, no shared memory (docs/running.md); a
#: shipped file (:func:`~swarm_supervisor.config.shipped`).
PROFILE_NAME = 'fastdds_localhost.xml'
SHM = Path('/dev/shm')
SHM_PREFIXES = ('fastrtps_', 'fast_datasharing', 'sem.fastrtps_')
#: Domains 1..100 keep every Fast DDS port below Linux's ephemeral range (32768).
DOMAINS = range(1, 101)
LOCK_DIR = Path('/tmp')
#: What the live node logs once the world's stepped topics reach it (its subscriptions to
#: them are matched): the launcher starts the supervisor, whose announcement starts an
#: episode, only then, so the live view gets the whole episode however late it started.
LIVE_READY = 'live view following the world'
#: The polite stop: each signal to every group still running at once, then that many seconds'
#: wait. A node stuck in native code never runs Python's handlers; SIGABRT then makes the fault
#: handler (PYTHONFAULTHANDLER=1) write every thread's stack to its log before SIGKILL. 10.5 s
#: in all, so a stopped run is gone within the 15 s a user waits: a clean teardown of 51
#: processes at once takes about 5 s at most (docs/reliability.md), and a node closes its
#: outputs (the bag) before its teardown, so SIGTERM 6 s after SIGINT loses nothing.
LADDER = ((signal.SIGINT, 6.0), (signal.SIGTERM, 2.0), (signal.SIGABRT, 1.5),
          (signal.SIGKILL, 1.0))


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


def lock_domain(domain: int) -> IO | None:
    """Take ``domain`` if it is free: the open lock file (/tmp/mona-ros-domain-<id>.lock,
    flock) that holds it, or None if another process holds the lock or the domain's ports.

    The lock lasts while the file is open here or in a child that inherited it.
    """
    handle = open(LOCK_DIR / f'mona-ros-domain-{domain}.lock', 'w')
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        handle.close()
        return None
    if not domain_ports_free(domain):
        handle.close()
        return None
    return handle


def claim_domain(start: int | None = None) -> tuple[int, IO]:
    """The first free domain in 1..100 counting from ``start`` (default: our pid) and the
    lock file that holds it.

    Raises:
        RuntimeError: every domain is taken.
    """
    start = os.getpid() if start is None else start
    for k in range(len(DOMAINS)):
        domain = DOMAINS[(start + k) % len(DOMAINS)]
        handle = lock_domain(domain)
        if handle is not None:
            return domain, handle
    raise RuntimeError('no free ROS domain id in 1..100')


@contextlib.contextmanager
def private_domain() -> Iterator[int]:
    """Hold a free ROS domain id for the duration of the block."""
    domain, handle = claim_domain()
    with handle:
        yield domain


def default_profile() -> Path:
    """The shipped Fast DDS profile (the source tree's, else the installed package's).

    Raises:
        ParameterError: it is missing (a broken install).
    """
    return shipped(PROFILE_NAME)


def ros_environment(domain: int, profile: Path | None = None, log_dir: Path | None = None,
                    base: Mapping[str, str] | None = None) -> dict[str, str]:
    """The environment of a node process in ``domain``: ``base`` (default os.environ) with the
    domain, Fast DDS and ``profile`` (default :func:`default_profile`) alone deciding
    discovery, unbuffered output, Python's fault handler, rcl's logs in ``log_dir`` and this
    Python's executables first on PATH."""
    profile = default_profile() if profile is None else profile
    env = dict(os.environ if base is None else base)
    for key in ('ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_LOCALHOST_ONLY', 'ROS_STATIC_PEERS'):
        env.pop(key, None)
    env.update(ROS_DOMAIN_ID=str(domain), RMW_IMPLEMENTATION='rmw_fastrtps_cpp',
               FASTRTPS_DEFAULT_PROFILES_FILE=str(profile), PYTHONUNBUFFERED='1',
               PYTHONFAULTHANDLER='1', RCUTILS_LOGGING_BUFFERED_STREAM='0',
               PATH=f'{python_bin()}{os.pathsep}{env.get("PATH", "")}')
    if log_dir is not None:
        env['ROS_LOG_DIR'] = str(log_dir)
    return env


def local_address(peers: Sequence[str]) -> str | None:
    """The first of ``peers`` (IPv4 addresses) that belongs to this host, or None.

    An address is this host's if a socket can bind to it: no parsing of interface tables, and
    it answers for the network namespace the process runs in.
    """
    for peer in peers:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind((peer, 0))
            except OSError:
                continue
            return peer
    return None


def peers_profile(address: str, peers: Sequence[str]) -> str:
    """A Fast DDS profile for a run across hosts: the loopback profile's design (one UDPv4
    transport, unicast discovery, no shared memory, no multicast) on this host's LAN
    ``address``, announcing itself to participant ids 0..119 at every one of ``peers``.

    Every host of the run gets the same peer list and finds its own address in it, so one
    command line, with only ``--role`` and ``--robots`` changed, serves every host.
    """
    peer_locators = ''.join(
        f'\n          <locator><udpv4><address>{peer}</address></udpv4></locator>'
        for peer in peers)
    return f"""<?xml version="1.0" encoding="UTF-8" ?>
<!--
  Written by scripts/swarm.sh for a run across hosts, peers {','.join(peers)}; this host
  is {address}. All traffic on that address; discovery by unicast to participant ids 0..119
  of the domain at every peer (docs/running.md, "Across machines").
-->
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <transport_descriptors>
    <transport_descriptor>
      <transport_id>lan_udp</transport_id>
      <type>UDPv4</type>
      <interfaceWhiteList>
        <address>{address}</address>
      </interfaceWhiteList>
      <maxInitialPeersRange>120</maxInitialPeersRange>
    </transport_descriptor>
  </transport_descriptors>

  <participant profile_name="mona_swarm_peers" is_default_profile="true">
    <rtps>
      <useBuiltinTransports>false</useBuiltinTransports>
      <userTransports>
        <transport_id>lan_udp</transport_id>
      </userTransports>
      <builtin>
        <metatrafficUnicastLocatorList>
          <locator><udpv4><address>{address}</address></udpv4></locator>
        </metatrafficUnicastLocatorList>
        <initialPeersList>{peer_locators}
        </initialPeersList>
      </builtin>
      <defaultUnicastLocatorList>
        <locator><udpv4><address>{address}</address></udpv4></locator>
      </defaultUnicastLocatorList>
    </rtps>
  </participant>
</profiles>
"""


def python_bin() -> Path:
    """The folder of this Python's executables (the venv's bin, where pip puts the nodes)."""
    return Path(sys.executable).parent


def start_group(command: Sequence[str], log: Path, env: Mapping[str, str],
                pass_fds: Sequence[int] = (), on_parent_death: int | None = None
                ) -> subprocess.Popen:
    """Start ``command`` in its own session and process group (so a Ctrl-C in the terminal
    does not reach it), stdin from /dev/null, stdout and stderr to ``log``; ``pass_fds`` are
    inherited (the domain's lock). With ``on_parent_death``, it gets that signal when this
    thread ends (:mod:`.child`): call from a thread that lasts as long as this process."""
    setup = functools.partial(child.setup, os.getpid(), on_parent_death)
    with open(log, 'wb') as output:
        return subprocess.Popen(list(command), stdin=subprocess.DEVNULL, stdout=output,
                                stderr=subprocess.STDOUT, env=dict(env), pass_fds=pass_fds,
                                start_new_session=True, preexec_fn=setup)


def signal_group(process: subprocess.Popen, sig: int) -> None:
    """Send ``sig`` to the process group that ``process`` leads, if it still exists."""
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(process.pid, sig)


def wait_gone(processes: Sequence[subprocess.Popen], seconds: float,
              interrupted: Callable[[], bool] = lambda: False) -> bool:
    """Wait until none of ``processes`` runs (True), ``seconds`` pass or ``interrupted()``."""
    deadline = time.monotonic() + seconds
    # Poll every one (a list, not any()): each ended process is reaped at once, no zombie.
    while [process for process in processes if process.poll() is None]:
        if time.monotonic() >= deadline or interrupted():
            return False
        time.sleep(0.2)
    return True


def wait_for_log(process: subprocess.Popen, log: Path, text: str, seconds: float,
                 interrupted: Callable[[], bool] = lambda: False) -> bool:
    """Wait until ``log`` (``process``'s output) holds ``text`` (True), or ``process`` ends,
    ``seconds`` pass or ``interrupted()`` (False)."""
    deadline = time.monotonic() + seconds
    while text not in log.read_text(errors='replace'):
        if process.poll() is not None or time.monotonic() >= deadline or interrupted():
            return False
        time.sleep(0.1)
    return True


def stop_groups(processes: Sequence[subprocess.Popen], grace: float = LADDER[0][1],
                say: Callable[[str], None] | None = None,
                signalled: Callable[[], None] | None = None) -> dict[int, signal.Signals]:
    """Stop the process groups of ``processes``: each signal of :data:`LADDER` to the groups
    whose leader still runs, the first one followed by ``grace`` seconds. ``say`` hears each
    escalation; ``signalled()`` runs once the first signal is out (within its wait: slow work
    on a loaded machine must not delay the signal). Returns pid -> the last signal that
    process needed (none if it had ended)."""
    needed: dict[int, signal.Signals] = {}
    previous = None
    for sig, wait in ((LADDER[0][0], grace), *LADDER[1:]):
        live = [process for process in processes if process.poll() is None]
        if not live:
            break
        if previous is not None and say is not None:
            note = ' (stacks in their logs)' if sig == signal.SIGABRT else ''
            say(f'{sig.name} to {len(live)} process(es) still running {previous[1]:g} s after '
                f'{previous[0].name}{note}')
        began = time.monotonic()
        for process in live:
            needed[process.pid] = sig
            signal_group(process, sig)
        if signalled is not None and previous is None:
            signalled()
        if wait_gone(live, wait - (time.monotonic() - began)):
            break
        previous = (sig, wait)
    for process in processes:  # anything left in a group whose leader is gone
        signal_group(process, signal.SIGKILL)
    return needed


def stop_group(process: subprocess.Popen, grace: float = 10.0) -> int:
    """Stop one process and its group with the ladder; return its exit status."""
    stop_groups([process], grace)
    return process.wait()


def describe(returncode: int) -> str:
    """A process's end in words: 'exit status 3', 'killed by SIGKILL'."""
    if returncode < 0:
        return f'killed by {signal.Signals(-returncode).name}'
    return f'exit status {returncode}'


def group_pids(pgid: int) -> list[int]:
    """The live processes of process group ``pgid``."""
    return _groups({pgid}).get(pgid, [])


def _groups(pgids: set[int], stop: Callable[[], bool] | None = None
            ) -> dict[int, list[int]]:
    """Process group id -> its live processes, for the groups in ``pgids`` (one /proc scan,
    cut short once ``stop()`` holds)."""
    found: dict[int, list[int]] = {}
    for stat in Path('/proc').glob('[0-9]*/stat'):
        if stop is not None and stop():
            break
        with contextlib.suppress(OSError, ValueError, IndexError):
            fields = stat.read_text().rsplit(')', 1)[1].split()
            pgid = int(fields[2])
            if pgid in pgids and fields[0] != 'Z':  # a zombie is gone, only not yet reaped
                found.setdefault(pgid, []).append(int(stat.parent.name))
    return found


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


def _shm_names(text: str) -> set[str]:
    """The Fast DDS /dev/shm file names in ``text``."""
    return {word[len('/dev/shm/'):] for word in text.split()
            if word.startswith('/dev/shm/') and word[len('/dev/shm/'):].startswith(SHM_PREFIXES)}


def mapped_shm(pids: Sequence[int] | None = None, stop: Callable[[], bool] | None = None
               ) -> set[str]:
    """The Fast DDS /dev/shm files that the given processes (default: all) map or hold open
    (those of the processes read before ``stop()`` held, if it does)."""
    used: set[str] = set()
    procs = [Path('/proc') / str(pid) for pid in pids] if pids is not None else \
        list(Path('/proc').glob('[0-9]*'))
    for proc in procs:
        if stop is not None and stop():
            break
        with contextlib.suppress(OSError):
            used |= _shm_names((proc / 'maps').read_text())
        with contextlib.suppress(OSError):
            for fd in (proc / 'fd').iterdir():
                with contextlib.suppress(OSError):
                    used |= _shm_names(os.readlink(fd))
    return used


def groups_shm(pgids: Sequence[int], stop: Callable[[], bool] | None = None) -> set[str]:
    """The /dev/shm files the processes of groups ``pgids`` map now (a killed one can't tell);
    the scan ends early once ``stop()`` holds: on a machine crowded by a start-up it reads
    dozens of processes' maps at a small share of a core, and a signal must not wait for it."""
    return mapped_shm([pid for pids in _groups(set(pgids), stop).values() for pid in pids],
                      stop)


def remove_shm_leftovers(domain: int, seen: set[str] | frozenset[str] = frozenset()
                         ) -> list[str]:
    """Remove the Fast DDS files of a finished run that no live process uses: the port files
    of ``domain`` and the files its processes were ``seen`` mapping. Returns their names."""
    leftovers = sorted(((domain_shm_files(domain) | seen) & shm_files()) - mapped_shm())
    for name in leftovers:
        with contextlib.suppress(FileNotFoundError):
            (SHM / name).unlink()
    return leftovers


@contextlib.contextmanager
def busy_cores(count: int | None = None, limit: float = 900.0) -> Iterator[None]:
    """Keep ``count`` cores (default: all) busy with spinning processes during the block.

    A busy machine (CI, other users) shows races a quiet one hides: the tests and the soak
    benchmark use this. The loops end with the block, and by themselves after ``limit``
    seconds whatever happens to the caller, so a crashed run cannot leave a machine loaded.
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
