"""The Mona firmware in simavr, for ``driver_hil`` (docs/driver.md, "Hardware in the loop"):
each robot's image built with firmware/mona's own Makefile (:func:`build_images`, one build
at a time on a machine: :func:`make`) and run in its own ``monasim`` process (firmware/sim) in
simulated time (:class:`Firmware`). The emulated arena that paces and feeds them is
:mod:`swarm_world.driver.emulation`.
"""

from __future__ import annotations

import fcntl
import shutil
import subprocess
import tempfile
from pathlib import Path

from mona_controller.link.frame import START, size

REPO = Path(__file__).resolve().parents[4]
FIRMWARE = REPO / 'firmware'


class HilError(Exception):
    """A setting or a missing tool that stops the harness before it starts (exit 2)."""


class FirmwareError(Exception):
    """A firmware process that ended or crashed while the harness ran (exit 1)."""


class Firmware:
    """One robot's firmware image in a ``monasim`` process, run in simulated time."""

    def __init__(self, monasim: Path, image: Path, log: Path) -> None:
        self.process = subprocess.Popen([str(monasim), str(image)], stdin=subprocess.PIPE,
                                        stdout=subprocess.PIPE, stderr=log.open('w'),
                                        text=True, bufsize=1)
        self.pwm = (0, 0, 0, 0, 0)  # pwm_l, dir_l, pwm_r, dir_r, cleaner
        self.tx = bytearray()
        self.pending: list[str] = []

    def send(self, commands: list[str]) -> None:
        """Send the commands (the process runs them while the others run theirs)."""
        assert self.process.stdin
        self.process.stdin.write(''.join(f'{c}\n' for c in commands))
        self.process.stdin.flush()
        self.pending = commands

    def collect(self) -> None:
        """Read the events up to the end (``T``) of each command sent."""
        assert self.process.stdout
        commands = self.pending
        done = 0
        while done < len(commands):
            line = self.process.stdout.readline()
            if not line:
                raise FirmwareError('monasim ended: ' + ' '.join(commands[:3]))
            kind = line[0]
            if kind == 'T':
                done += 1
            elif kind == 'U':
                self.tx.append(int(line.split()[2], 16))
            elif kind == 'W':
                fields = line.split()
                self.pwm = tuple(int(v) for v in fields[2:7])  # type: ignore[assignment]
            elif kind == 'E':
                raise FirmwareError(f'the firmware crashed: {line.strip()}')

    def frames(self) -> list[bytes]:
        """The whole frames the firmware has transmitted so far (bytes between are dropped)."""
        out: list[bytes] = []
        while True:
            start = self.tx.find(START)
            if start < 0:
                self.tx.clear()
                return out
            del self.tx[:start]
            total = size(self.tx)
            if total is None or len(self.tx) < total:
                return out
            out.append(bytes(self.tx[:total]))
            del self.tx[:total]

    def stop(self) -> None:
        """End the process."""
        try:
            assert self.process.stdin
            self.process.stdin.write('quit\n')
            self.process.stdin.flush()
            self.process.wait(timeout=2)
        except (OSError, subprocess.TimeoutExpired, ValueError):
            self.process.kill()
            self.process.wait()


def build_images(robots: int, folder: Path) -> tuple[list[Path], Path]:
    """Each robot's firmware (ROBOT_ID = i) with firmware/mona's own Makefile, and monasim."""
    missing = [tool for tool in ('avr-gcc', 'make', 'cc') if shutil.which(tool) is None]
    if missing or not Path('/usr/include/simavr/sim_avr.h').exists():
        raise HilError(f'the firmware tools are missing ({", ".join(missing) or "simavr"}): '
                       'run make firmware-tools')
    images = []
    for robot in range(robots):
        work = folder / f'robot_{robot}'
        work.mkdir(parents=True, exist_ok=True)
        for name in ('src', 'Makefile'):  # the tree's sources, built out of the tree
            link = work / name
            if not link.exists():
                link.symlink_to(FIRMWARE / 'mona' / name)
        make(work, f'ROBOT_ID={robot}', 'mona.elf')
        images.append(work / 'mona.elf')
    make(FIRMWARE / 'sim')
    return images, FIRMWARE / 'sim' / 'monasim'


def make(folder: Path, *targets: str) -> None:
    """``make -s -C folder targets``, one build at a time on this machine: runs started
    together (parallel tests) build firmware/sim's one monasim, and a half-written one fails
    to start."""
    with open(Path(tempfile.gettempdir()) / 'mona-firmware-build.lock', 'w') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        subprocess.run(['make', '-s', '-C', str(folder), *targets], check=True,
                       capture_output=True, timeout=120)
