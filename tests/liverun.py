"""Live runs (``mona-swarm run --live``, ``scripts/swarm.sh --live``) as the tests watch them:
a command read as it prints, whether the web app can connect, a client that watches from the
start, and the two runs the live tier (tests/live) and the browser tier (tests/browser) share.

The shared runs are session fixtures (tests/conftest.py: ``embedded_live``, ``node_live``), each
started once per pytest process by its first test; the modules using one are one unit of
work (tests/suite.py's ``SHARED_RUNS``), so one worker runs them all, in the order listed there:

- ``embedded_live``: ``mona-swarm run --live --bag --pace 3`` (N = 12, seed 2, 200 s, among
  examples/obstacle_layout.yaml's obstacles): about 67 s of wall time from its start. (The
  browser's live test watches a run of its own, :func:`held_embedded_run`, whose episode
  waits for the page: on a busy 2-core machine this one had ended before a page had loaded.)
- ``node_live``: ``scripts/swarm.sh --live`` (lockstep, N = 5, seed 4, 80 s, the same
  obstacles): lockstep runs about as fast as real time here.

A client subscribes as soon as the live view listens and keeps what it sees until the episode
is 10 s of sim time old (:attr:`SharedRun.watched`). After its episode each run lingers, its
live view serving the final state, until the last test of its unit is over (tests/suite.py's
``ENDED_EARLY``); then Ctrl-C, which must end it with status 0, nothing rewritten (else an
error in that test's teardown).
"""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from foxclient import LEGACY_SUBPROTOCOL, Capture, connect_when_up
from harness import REPO, free_port
from swarmrun import SwarmRun

MONA_SWARM = Path(sys.executable).parent / 'mona-swarm'
OBSTACLES = REPO / 'examples' / 'obstacle_layout.yaml'
#: The sim time (ns) the watching client's capture reaches before it stops.
WATCHED_NS = 10 * 10**9


class LiveRun:
    """A command serving a live view: started, read line by line, stopped by SIGINT."""

    def __init__(self, command: list[str], env: dict[str, str] | None = None) -> None:
        """Start ``command`` (its stdout and stderr are read as one stream)."""
        self.process = subprocess.Popen(command, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True, env=env,
                                        start_new_session=True)
        self.lines: list[str] = []
        self.url = ''          # the live view's ws:// URL, once printed
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.append(line)

    @property
    def output(self) -> str:
        """Everything the command printed so far."""
        return ''.join(self.lines)

    def wait_for(self, text: str, timeout: float) -> str:
        """The first printed line holding ``text``; fails the test if it never comes."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for line in list(self.lines):
                if text in line:
                    return line
            if self.process.poll() is not None and not self._reader.is_alive():
                break
            time.sleep(0.2)
        pytest.fail(f'no {text!r} in {timeout:.0f} s (exit {self.process.poll()}):\n'
                    f'{self.output[-3000:]}')

    def stop(self, timeout: float = 60.0) -> int | None:
        """Ctrl-C (SIGINT to its process group), as a user ends a lingering live view; the
        exit status (None if it had to be killed)."""
        if self.process.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                self.process.send_signal(signal.SIGINT)
            try:
                return self.process.wait(timeout)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    self.process.kill()
                self.process.wait(10)
                return None
        return self.process.returncode


def accepts_legacy_subprotocol(url: str) -> bool:
    """Whether the live view at ``url`` accepts a client offering only the subprotocol the
    web build offers (foxglove-sdk's own server answers such a client HTTP 400)."""
    from websockets.exceptions import InvalidHandshake
    from websockets.sync.client import connect

    try:
        with connect(url, subprotocols=[LEGACY_SUBPROTOCOL], open_timeout=10) as socket:
            return socket.subprotocol == LEGACY_SUBPROTOCOL
    except (InvalidHandshake, OSError):
        return False


class Watcher:
    """A Foxglove client in a thread of its own: it connects as soon as the live view at
    ``url`` listens and captures until ``done(capture)`` holds."""

    def __init__(self, url: str, done: Callable[[Capture], bool], seconds: float = 300.0):
        self.capture: Capture | None = None
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._watch, args=(url, done, seconds),
                                         daemon=True)
        self._thread.start()

    def _watch(self, url: str, done: Callable[[Capture], bool], seconds: float) -> None:
        try:
            self.capture = connect_when_up(url, timeout=120, seconds=seconds, done=done)
        except BaseException as error:  # noqa: BLE001 - raised in the test's thread
            self.error = error

    def result(self, timeout: float = 400.0) -> Capture:
        """What the client saw (it raises what the client raised)."""
        self._thread.join(timeout)
        if self._thread.is_alive():
            pytest.fail(f'the watching client still runs after {timeout:.0f} s')
        if self.error is not None:
            raise self.error
        assert self.capture is not None
        return self.capture


def watched_enough(capture: Capture) -> bool:
    """The announcement, the obstacles, a cue map, three metric samples and poses until
    :data:`WATCHED_NS` of sim time."""
    poses = capture.messages.get('/world/poses', ())
    return bool(poses) and poses[-1][0] >= WATCHED_NS and \
        len(capture.messages.get('/metrics/coherency', ())) >= 3 and \
        {'/world/cue_map', '/episode', '/world/obstacles'} <= set(capture.messages)


@dataclass
class SharedRun:
    """A lingering live run several tests look at."""

    run: LiveRun | SwarmRun  #: the process
    population: int
    seed: int
    duration: float
    out: Path              #: the run's output folder
    url: str               #: its live view
    watcher: Watcher | None  #: a client that watched it from the start (None: no such client)
    lingering: Callable[[float], object] = field(repr=False)  #: waits for the linger

    @property
    def watched(self) -> Capture:
        """What a client saw from the start (sim time 0 to :data:`WATCHED_NS`)."""
        assert self.watcher is not None, 'no client watched this run'
        return self.watcher.result()

    def wait_lingering(self, timeout: float = 300.0) -> None:
        """Until the episode is over, every output written, and the live view lingers."""
        self.lingering(timeout)


def text_of(path: Path) -> str | None:
    return path.read_text() if path.exists() else None


def embedded_live_run(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SharedRun]:
    """The embedded runner's lingering live run: N = 12, seed 2, 200 s at pace 3, with a
    bag, among the example obstacles."""
    out = tmp_path_factory.mktemp('embedded_live') / 'run'
    yield from _embedded_run(out, 200.0, 3.0, '--bag', watched=True)


def held_embedded_run(out: Path, duration: float, pace: float) -> Iterator[SharedRun]:
    """A lingering embedded live run (N = 12, seed 2, ``duration`` s at ``pace`` sim seconds
    per wall second, among the example obstacles) that holds its episode at t = 0 until a
    viewer has subscribed (``--wait-for-viewer``): the test's own viewer sees it from its
    start, however long its page takes to load."""
    yield from _embedded_run(out, duration, pace, '--wait-for-viewer', '600', watched=False)


def _embedded_run(out: Path, duration: float, pace: float, *extra: str, watched: bool
                  ) -> Iterator[SharedRun]:
    live = LiveRun([str(MONA_SWARM), 'run', '--population', '12', '--seed', '2',
                    '--duration', f'{duration:g}', '--out', str(out), '--config', str(OBSTACLES),
                    '--live', '--live-port', '0', '--pace', f'{pace:g}', '--linger', '900',
                    *extra])
    try:
        live.url = live.wait_for('live view on ws://', 120).split('live view on ')[1].split()[0]
        yield SharedRun(live, 12, 2, duration, out, live.url,
                        Watcher(live.url, watched_enough) if watched else None,
                        lambda timeout: live.wait_for('keeps serving its final state', timeout))
        record = text_of(out / 'episode.json')
    finally:
        status = live.stop()
    assert status == 0, f'Ctrl-C ended the lingering run with {status}:\n{live.output[-3000:]}'
    assert 'live view closed' in live.output and 'Traceback' not in live.output
    assert text_of(out / 'episode.json') == record  # nothing rewritten after the end


def node_live_run(tmp_path_factory: pytest.TempPathFactory) -> Iterator[SharedRun]:
    """The node system's lingering live run: lockstep, N = 5, seed 4, 80 s, among the
    example obstacles."""
    port = free_port()
    out = tmp_path_factory.mktemp('node_live') / 'run'
    population, seed, duration = 5, 4, 80.0  # given once: the checks read them from here
    swarm = SwarmRun(out, ['--population', str(population), '--duration', f'{duration:g}',
                           '--seed', str(seed),
                           '--mode', 'lockstep', '--config', str(OBSTACLES), '--live',
                           '--live-port', str(port), '--linger', '900',
                           '-p', 'real_time_factor:=1.0'])  # watchable: at most real time
    url = f'ws://127.0.0.1:{port}'
    try:
        yield SharedRun(swarm, population, seed, duration, out, url, Watcher(url, watched_enough),
                        lambda timeout: swarm.wait_for(
                            lambda: 'keeps serving its final state' in swarm.stderr,
                            'the end of the run', timeout))
        report = text_of(out / 'run.json')
        if swarm.process.poll() is None:
            swarm.process.send_signal(signal.SIGINT)  # Ctrl-C, as a user ends the linger
        status = swarm.wait(120)
    finally:
        swarm.stop()
    assert status == 0, f'Ctrl-C ended the lingering run with {status}:\n{swarm.stderr}'
    assert 'done:' in swarm.stderr and 'FAILED' not in swarm.stderr, swarm.stderr
    assert text_of(out / 'run.json') == report  # nothing rewritten after the end
