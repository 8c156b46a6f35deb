"""A live run (``mona-swarm run --live`` or ``scripts/swarm.sh --live``) as the browser tests
watch it: its process, its output read as it comes, and whether the app can connect."""

from __future__ import annotations

import contextlib
import signal
import subprocess
import threading
import time

import pytest

#: The subprotocol Foxglove's web build 1.48.0 offers (its only one).
LEGACY_SUBPROTOCOL = 'foxglove.websocket.v1'


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
